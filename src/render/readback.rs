//! The host-visible ring that frames copy their outputs into with their own commands
//! ([`FrameRing`]): the frame drivers and the temporal technique record into it, and read each
//! frame's counters, image and pixel states from it after the submission completed.

use ash::vk;

use crate::render::passes::raytrace::COUNTER_WORDS;
use crate::render::{Aov, RenderSettings};
use crate::vk::{host_read_barrier, Buffer, Context, MemoryLocation, VkError, VkResult};

/// What each slot of a [`FrameRing`] holds besides the counters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RingContents {
    /// Tonemapped RGBA8 (PNG output, FLIP).
    pub rgba8: bool,
    /// Linear colour (EXR output).
    pub color: bool,
    /// Primary-hit AOVs.
    pub aov: bool,
    /// Reprojection pixel states (where each pixel's colour came from).
    pub states: bool,
}

/// Counter words every ring slot holds (rays by kind, samples, reprojection statistics).
pub const RING_COUNTERS: usize = crate::interface::reproject::C_HISTOGRAM as usize;
const _: () = assert!(COUNTER_WORDS <= RING_COUNTERS);
const AOV_BYTES: u64 = std::mem::size_of::<Aov>() as u64;

/// Host-visible slots that frames copy their outputs into with their own commands: one slot
/// per frame of a burst, read after the burst's submission completed, so reading a frame's
/// image or statistics needs no extra submission, no allocation and no host work between
/// frames.
pub struct FrameRing {
    buffer: Buffer,
    slots: u32,
    pixels: u64,
    contents: RingContents,
}

/// Where a frame's outputs are, for [`FrameRing::record_copy`].
pub struct RingSources<'a> {
    /// Counters (the first [`RING_COUNTERS`] words at most are copied).
    pub counters: &'a Buffer,
    /// Tonemapped RGBA8, one `u32` per pixel.
    pub rgba8: &'a Buffer,
    /// Linear colour, `vec4` per pixel.
    pub color: &'a Buffer,
    /// AOVs per pixel, when the frame writes them.
    pub aov: Option<&'a Buffer>,
    /// Reprojection pixel states.
    pub states: Option<&'a Buffer>,
}

impl FrameRing {
    /// Bytes of one slot.
    pub fn slot_bytes(pixels: u64, contents: RingContents) -> u64 {
        let mut b = RING_COUNTERS as u64 * 4;
        for (on, per_pixel) in [
            (contents.rgba8, 4),
            (contents.color, 16),
            (contents.aov, AOV_BYTES),
            (contents.states, 4),
        ] {
            if on {
                b += pixels * per_pixel;
            }
        }
        b
    }

    /// A ring of `slots` slots for images of `pixels` pixels.
    pub fn new(
        ctx: &Context,
        name: &str,
        slots: u32,
        pixels: u64,
        contents: RingContents,
    ) -> VkResult<Self> {
        let slots = slots.max(1);
        let buffer = Buffer::new(
            ctx,
            name,
            Self::slot_bytes(pixels, contents) * u64::from(slots),
            vk::BufferUsageFlags::empty(),
            MemoryLocation::GpuToCpu,
        )?;
        Ok(Self {
            buffer,
            slots,
            pixels,
            contents,
        })
    }

    /// Number of slots.
    pub fn slots(&self) -> u32 {
        self.slots
    }

    /// What the slots hold.
    pub fn contents(&self) -> RingContents {
        self.contents
    }

    /// Byte offsets in slot `slot`: counters, rgba8, colour, AOVs, states.
    fn offsets(&self, slot: u32) -> [u64; 5] {
        let c = self.contents;
        let base = Self::slot_bytes(self.pixels, c) * u64::from(slot);
        let counters = base;
        let rgba8 = counters + RING_COUNTERS as u64 * 4;
        let color = rgba8 + if c.rgba8 { self.pixels * 4 } else { 0 };
        let aov = color + if c.color { self.pixels * 16 } else { 0 };
        let states = aov + if c.aov { self.pixels * AOV_BYTES } else { 0 };
        [counters, rgba8, color, aov, states]
    }

    /// Records copies of a frame's outputs into slot `slot` (what the ring holds), then the
    /// barrier that makes them visible to the host after the submission's fence.
    pub fn record_copy(
        &self,
        device: &ash::Device,
        cmd: vk::CommandBuffer,
        slot: u32,
        src: &RingSources<'_>,
    ) {
        debug_assert!(slot < self.slots);
        let [counters, rgba8, color, aov, states] = self.offsets(slot);
        let c = self.contents;
        let n = self.pixels;
        let words = (src.counters.size() / 4).min(RING_COUNTERS as u64);
        src.counters
            .record_copy_to(device, cmd, &self.buffer, 0, counters, words * 4);
        if c.rgba8 {
            src.rgba8
                .record_copy_to(device, cmd, &self.buffer, 0, rgba8, n * 4);
        }
        if c.color {
            src.color
                .record_copy_to(device, cmd, &self.buffer, 0, color, n * 16);
        }
        if let (true, Some(a)) = (c.aov, src.aov) {
            a.record_copy_to(device, cmd, &self.buffer, 0, aov, n * AOV_BYTES);
        }
        if let (true, Some(s)) = (c.states, src.states) {
            s.record_copy_to(device, cmd, &self.buffer, 0, states, n * 4);
        }
        host_read_barrier(device, cmd);
    }

    fn read<T: bytemuck::Pod>(&self, offset: u64, count: usize) -> VkResult<Vec<T>> {
        self.buffer
            .mapped_read(offset, count)
            .ok_or_else(|| VkError::Invalid("frame ring is not host-visible".into()))
    }

    /// The counters of slot `slot` ([`RING_COUNTERS`] words).
    pub fn counters(&self, slot: u32) -> VkResult<Vec<u32>> {
        self.read(self.offsets(slot)[0], RING_COUNTERS)
    }

    /// The tonemapped image of slot `slot` (empty when the ring holds none).
    pub fn rgba8(&self, slot: u32) -> VkResult<Vec<u8>> {
        if !self.contents.rgba8 {
            return Ok(Vec::new());
        }
        self.read(self.offsets(slot)[1], self.pixels as usize * 4)
    }

    /// The linear colour of slot `slot` (empty when the ring holds none).
    pub fn color(&self, slot: u32) -> VkResult<Vec<[f32; 4]>> {
        if !self.contents.color {
            return Ok(Vec::new());
        }
        self.read(self.offsets(slot)[2], self.pixels as usize)
    }

    /// The AOVs of slot `slot` (empty when the ring holds none).
    pub fn aov(&self, slot: u32) -> VkResult<Vec<Aov>> {
        if !self.contents.aov {
            return Ok(Vec::new());
        }
        self.read(self.offsets(slot)[3], self.pixels as usize)
    }

    /// The reprojection pixel states of slot `slot` (empty when the ring holds none).
    pub fn states(&self, slot: u32) -> VkResult<Vec<u32>> {
        if !self.contents.states {
            return Ok(Vec::new());
        }
        self.read(self.offsets(slot)[4], self.pixels as usize)
    }
}

/// Host-visible bytes of a frame's own readback slot at `settings` (counters, RGBA8, colour
/// and the AOVs when written).
pub fn readback_bytes(settings: &RenderSettings, aov: bool) -> u64 {
    FrameRing::slot_bytes(
        settings.pixels(),
        RingContents {
            rgba8: true,
            color: true,
            aov,
            states: false,
        },
    )
}
