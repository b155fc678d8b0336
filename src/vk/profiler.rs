//! GPU timestamps: named scopes recorded into command buffers and read back as milliseconds
//! ([`GpuProfiler`]), grouped by frame for bursts ([`FrameTiming`]).

use std::sync::Arc;

use ash::vk;

use super::context::Shared;
use super::{CallExt, Context, VkError, VkResult};

/// GPU timestamp scopes: `begin(name)`/`end` pairs recorded into command buffers, read back
/// as milliseconds (using the device's `timestampPeriod`). Scopes may be grouped into
/// frames ([`Self::begin_frame`]/[`Self::end_frame`]), so that a burst of frames recorded
/// back to back is timed frame by frame.
///
/// On lavapipe the "GPU" is the CPU: durations are CPU time spent executing the commands.
pub struct GpuProfiler {
    shared: Arc<Shared>,
    pool: vk::QueryPool,
    capacity: u32,
    period_ns: f64,
    /// Name and first query of each scope, in recording order.
    scopes: Vec<(String, u32)>,
    open: Option<usize>,
    /// Per frame: its first scope, and the queries of its whole-frame timestamps.
    frames: Vec<FrameQueries>,
    next_query: u32,
}

struct FrameQueries {
    first_scope: usize,
    begin: Option<u32>,
    end: Option<u32>,
}

/// GPU time of one frame of a burst.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameTiming {
    /// From the frame's first command to its last, barriers and untimed work included.
    pub total_ms: f64,
    /// The frame's scopes in recording order.
    pub passes: Vec<(String, f64)>,
}

impl GpuProfiler {
    /// Creates a profiler for up to `max_scopes` scopes per frame. Fails with a clear error
    /// where the queue cannot write timestamps.
    pub fn new(ctx: &Context, max_scopes: u32) -> VkResult<Self> {
        if !ctx.features().timestamps {
            return Err(VkError::MissingFeature {
                device: ctx.info().name.clone(),
                feature:
                    "timestamps on the graphics+compute queue (per-pass GPU times unavailable)"
                        .into(),
            });
        }
        let capacity = max_scopes.max(1) * 2;
        let info = vk::QueryPoolCreateInfo::default()
            .query_type(vk::QueryType::TIMESTAMP)
            .query_count(capacity);
        // SAFETY: valid create info.
        let pool =
            unsafe { ctx.device().create_query_pool(&info, None) }.call("vkCreateQueryPool")?;
        Ok(Self {
            shared: ctx.shared.clone(),
            pool,
            capacity,
            period_ns: f64::from(ctx.info().timestamps.period_ns),
            scopes: Vec::new(),
            open: None,
            frames: Vec::new(),
            next_query: 0,
        })
    }

    /// How many scopes (frames count as one each) fit between two resets.
    pub fn capacity_scopes(&self) -> u32 {
        self.capacity / 2
    }

    fn timestamp(&mut self, cmd: vk::CommandBuffer) -> Option<u32> {
        let query = self.next_query;
        if query >= self.capacity {
            return None;
        }
        self.next_query += 1;
        // SAFETY: query index within the pool, which was reset before this frame's scopes.
        unsafe {
            self.shared.device.cmd_write_timestamp2(
                cmd,
                vk::PipelineStageFlags2::ALL_COMMANDS,
                self.pool,
                query,
            )
        };
        Some(query)
    }

    /// Starts a frame: later scopes belong to it, and its whole duration is timed too.
    pub fn begin_frame(&mut self, cmd: vk::CommandBuffer) {
        self.end(cmd);
        self.end_frame(cmd);
        let first_scope = self.scopes.len();
        // Keep the pair's second query free, so an open frame can always be closed.
        let begin = if self.next_query + 2 <= self.capacity {
            self.timestamp(cmd)
        } else {
            log::warn!("GPU profiler full: frame not timed");
            None
        };
        super::memory_barrier(&self.shared.device, cmd);
        self.frames.push(FrameQueries {
            first_scope,
            begin,
            end: None,
        });
    }

    /// Ends the frame started by [`Self::begin_frame`] (closing an open scope first).
    pub fn end_frame(&mut self, cmd: vk::CommandBuffer) {
        self.end(cmd);
        if let Some(f) = self.frames.last() {
            if f.begin.is_some() && f.end.is_none() {
                super::memory_barrier(&self.shared.device, cmd);
                let end = self.timestamp(cmd);
                if let Some(f) = self.frames.last_mut() {
                    f.end = end;
                }
            }
        }
    }

    /// Resets the pool (record once per frame, before the first scope).
    pub fn reset(&mut self, cmd: vk::CommandBuffer) {
        // SAFETY: recording command buffer; the pool is ours.
        unsafe {
            self.shared
                .device
                .cmd_reset_query_pool(cmd, self.pool, 0, self.capacity)
        };
        self.scopes.clear();
        self.open = None;
        self.frames.clear();
        self.next_query = 0;
    }

    /// Opens scope `name` (scopes do not nest: an open scope is closed first).
    pub fn begin(&mut self, cmd: vk::CommandBuffer, name: &str) {
        if self.open.is_some() {
            self.end(cmd);
        }
        // Keep room for the scope's end and for closing an open frame.
        let reserve = if self
            .frames
            .last()
            .is_some_and(|f| f.begin.is_some() && f.end.is_none())
        {
            3
        } else {
            2
        };
        if self.next_query + reserve > self.capacity {
            log::warn!("GPU profiler full: scope '{name}' not timed");
            return;
        }
        let Some(query) = self.timestamp(cmd) else {
            return;
        };
        // lavapipe bins a timestamp into its rasterizer scene and writes it when the scene is
        // flushed; the barrier flushes it now, before the scope's work runs.
        super::memory_barrier(&self.shared.device, cmd);
        self.scopes.push((name.to_string(), query));
        self.open = Some(self.scopes.len() - 1);
    }

    /// Closes the open scope.
    pub fn end(&mut self, cmd: vk::CommandBuffer) {
        if let Some(i) = self.open.take() {
            let end = self.timestamp(cmd);
            debug_assert_eq!(end, Some(self.scopes[i].1 + 1));
        }
    }

    /// Milliseconds per scope, in recording order. Call after the submission completed.
    pub fn results(&self) -> VkResult<Vec<(String, f64)>> {
        let raw = self.raw()?;
        Ok(self.scopes.iter().map(|s| self.scope_ms(&raw, s)).collect())
    }

    /// Per frame ([`Self::begin_frame`]): its whole duration and its scopes. Scopes recorded
    /// before the first frame are not included. Call after the submissions completed.
    pub fn frame_results(&self) -> VkResult<Vec<FrameTiming>> {
        let raw = self.raw()?;
        let ms = |a: u32, b: u32| {
            raw[b as usize].saturating_sub(raw[a as usize]) as f64 * self.period_ns / 1e6
        };
        Ok(self
            .frames
            .iter()
            .enumerate()
            .map(|(i, f)| {
                let last_scope = self
                    .frames
                    .get(i + 1)
                    .map_or(self.scopes.len(), |n| n.first_scope);
                FrameTiming {
                    total_ms: match (f.begin, f.end) {
                        (Some(a), Some(b)) => ms(a, b),
                        _ => 0.0,
                    },
                    passes: self.scopes[f.first_scope..last_scope]
                        .iter()
                        .map(|s| self.scope_ms(&raw, s))
                        .collect(),
                }
            })
            .collect())
    }

    fn scope_ms(&self, raw: &[u64], (name, q): &(String, u32)) -> (String, f64) {
        let (a, b) = (raw[*q as usize], raw[*q as usize + 1]);
        (
            name.clone(),
            b.saturating_sub(a) as f64 * self.period_ns / 1e6,
        )
    }

    fn raw(&self) -> VkResult<Vec<u64>> {
        let mut raw = vec![0u64; self.next_query as usize];
        if raw.is_empty() {
            return Ok(raw);
        }
        // SAFETY: the queries were written by a completed submission.
        unsafe {
            self.shared.device.get_query_pool_results(
                self.pool,
                0,
                &mut raw,
                vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
            )
        }
        .call("vkGetQueryPoolResults")?;
        Ok(raw)
    }
}

impl Drop for GpuProfiler {
    fn drop(&mut self) {
        let pool = self.pool;
        // SAFETY: submissions using the pool completed (`retire` defers past timed-out ones).
        self.shared
            .retire(move |shared| unsafe { shared.device.destroy_query_pool(pool, None) });
    }
}
