//! Textures, samplers and images: where the encoded bytes come from, and decoding them.

use super::*;
use crate::scene::decoded::Decoded;

/// Where an image's encoded bytes come from.
pub(super) enum ImageBytes<'a> {
    Borrowed(&'a [u8]),
    Owned(Vec<u8>),
}

impl Loader<'_> {
    pub(super) fn texture(&mut self, t: usize, srgb: bool) -> Result<u32, SceneError> {
        if let Some(&s) = self.texture_of.get(&(t, srgb)) {
            return Ok(s);
        }
        let tex = &self.root.textures[t];
        let el = format!("texture {t}");
        let source = crate::scene::extensions::texture_source(tex).map_err(|e| self.err(&el, e))?;
        if source >= self.root.images.len() {
            return Err(self.err(
                &el,
                format!(
                    "image {source} does not exist ({} images)",
                    self.root.images.len()
                ),
            ));
        }
        let sampler = match tex.sampler {
            None => Sampler::default(),
            Some(s) => self.sampler(s.value())?,
        };
        let image = match self.image_of.get(&(source, srgb)) {
            Some(&i) => i,
            None => {
                self.scene.images.push(ImageData {
                    width: 0,
                    height: 0,
                    rgba8: Vec::new(),
                    mips: Vec::new(),
                    srgb,
                    ktx2: None,
                });
                self.image_sources.push(source);
                let i = (self.scene.images.len() - 1) as u32;
                self.image_of.insert((source, srgb), i);
                i
            }
        };
        self.scene.textures.push(Texture { image, sampler });
        let s = (self.scene.textures.len() - 1) as u32;
        self.texture_of.insert((t, srgb), s);
        Ok(s)
    }

    pub(super) fn sampler(&self, s: usize) -> Result<Sampler, SceneError> {
        use gj::texture::{MagFilter, MinFilter, WrappingMode};
        let el = format!("sampler {s}");
        let j = self.root.samplers.get(s).ok_or_else(|| {
            self.err(
                &el,
                format!("does not exist ({} samplers)", self.root.samplers.len()),
            )
        })?;
        let wrap = |w: &Checked<WrappingMode>, name: &str| match checked(w) {
            Some(WrappingMode::Repeat) => Ok(Wrap::Repeat),
            Some(WrappingMode::MirroredRepeat) => Ok(Wrap::MirroredRepeat),
            Some(WrappingMode::ClampToEdge) => Ok(Wrap::ClampToEdge),
            None => Err(self.err(&el, format!("invalid {name}"))),
        };
        let mag_linear = match j.mag_filter.as_ref().map(checked) {
            None => true,
            Some(Some(f)) => f == MagFilter::Linear,
            Some(None) => return Err(self.err(&el, "invalid magFilter")),
        };
        // Undefined minification: trilinear, rqr's choice where glTF leaves it open.
        let (min_linear, mipmaps, mip_linear) = match j.min_filter.as_ref().map(checked) {
            None => (true, true, true),
            Some(Some(f)) => match f {
                MinFilter::Nearest => (false, false, false),
                MinFilter::Linear => (true, false, false),
                MinFilter::NearestMipmapNearest => (false, true, false),
                MinFilter::LinearMipmapNearest => (true, true, false),
                MinFilter::NearestMipmapLinear => (false, true, true),
                MinFilter::LinearMipmapLinear => (true, true, true),
            },
            Some(None) => return Err(self.err(&el, "invalid minFilter")),
        };
        Ok(Sampler {
            wrap_s: wrap(&j.wrap_s, "wrapS")?,
            wrap_t: wrap(&j.wrap_t, "wrapT")?,
            mag_linear,
            min_linear,
            mip_linear,
            mipmaps,
        })
    }

    pub(super) fn image_bytes(
        &self,
        i: usize,
    ) -> Result<(ImageBytes<'_>, Option<String>), SceneError> {
        let j = &self.root.images[i];
        let el = self.image_element(i);
        let mime = j.mime_type.as_ref().map(|m| m.0.clone());
        if let Some(v) = j.buffer_view {
            let v = v.value();
            let view = self.root.buffer_views.get(v).ok_or_else(|| {
                self.err(
                    &el,
                    format!(
                        "buffer view {v} does not exist ({} buffer views)",
                        self.root.buffer_views.len()
                    ),
                )
            })?;
            let b = view.buffer.value();
            let buffer = self.buffers.data.get(b).ok_or_else(|| {
                self.err(&el, format!("buffer view {v}: buffer {b} does not exist"))
            })?;
            let start = view.byte_offset.map_or(0, |o| o.0);
            let end = start
                .checked_add(view.byte_length.0)
                .filter(|&e| e <= buffer.len() as u64);
            let Some(end) = end else {
                return Err(self.err(
                    &el,
                    format!(
                        "buffer view {v} (offset {start}, length {}) exceeds buffer {b} ({} bytes)",
                        view.byte_length.0,
                        buffer.len()
                    ),
                ));
            };
            return Ok((
                ImageBytes::Borrowed(&buffer[start as usize..end as usize]),
                mime,
            ));
        }
        let Some(uri) = &j.uri else {
            return Err(self.err(&el, "has neither uri nor bufferView"));
        };
        let mime = mime.or_else(|| {
            img::parse_data_uri(uri)
                .and_then(|r| r.ok())
                .map(|(m, _)| m)
        });
        Ok((ImageBytes::Owned(self.read_uri(&el, uri)?), mime))
    }

    pub(super) fn image_element(&self, i: usize) -> String {
        match &self.root.images[i].uri {
            Some(u) if !u.starts_with("data:") => format!("image {i} ({u})"),
            _ => format!("image {i}"),
        }
    }

    /// Decodes every referenced glTF image once (in parallel) and fills the scene images.
    pub(super) fn decode_images(&mut self) -> Result<(), SceneError> {
        let mut unique: Vec<usize> = self.image_sources.clone();
        unique.sort_unstable();
        unique.dedup();
        let mut jobs = Vec::with_capacity(unique.len());
        let (mut read, mut texels) = (0u64, 0u64);
        for &i in &unique {
            let (bytes, mime) = self.image_bytes(i)?;
            let data: &[u8] = match &bytes {
                ImageBytes::Borrowed(b) => b,
                ImageBytes::Owned(v) => {
                    read += v.len() as u64;
                    v
                }
            };
            // Undecodable headers are reported by the decoder below, with the reason.
            if let Ok((w, h)) = img::dimensions(data, mime.as_deref()) {
                texels += u64::from(w) * u64::from(h);
            }
            if read > MAX_READ_BYTES || texels > MAX_SCENE_TEXELS {
                return Err(self.err(
                    self.image_element(i),
                    format!("the scene's images exceed rqr's limit of {MAX_SCENE_TEXELS} texels or {MAX_READ_BYTES} bytes"),
                ));
            }
            jobs.push((i, (bytes, mime)));
        }
        let max = self.opts.max_image_size;
        let threads = std::thread::available_parallelism()
            .map_or(1, |n| n.get())
            .min(jobs.len())
            .max(1);
        let next = std::sync::atomic::AtomicUsize::new(0);
        let jobs_ref = &jobs;
        let next_ref = &next;
        let results: Vec<(usize, Result<Decoded, String>)> = std::thread::scope(|s| {
            let handles: Vec<_> = (0..threads)
                .map(|_| {
                    s.spawn(move || {
                        let mut out = Vec::new();
                        loop {
                            let k = next_ref.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                            let Some((i, (bytes, mime))) = jobs_ref.get(k) else {
                                break;
                            };
                            let data: &[u8] = match bytes {
                                ImageBytes::Borrowed(b) => b,
                                ImageBytes::Owned(v) => v,
                            };
                            out.push((*i, img::decode(data, mime.as_deref(), max)));
                        }
                        out
                    })
                })
                .collect();
            handles
                .into_iter()
                .flat_map(|h| {
                    h.join().unwrap_or_else(|_| {
                        vec![(usize::MAX, Err("image decoder panicked".into()))]
                    })
                })
                .collect()
        });
        drop(jobs);
        let mut decoded: HashMap<usize, Decoded> = HashMap::new();
        let mut first_error: Option<(usize, String)> = None;
        for (i, r) in results {
            match r {
                Ok(d) => {
                    decoded.insert(i, d);
                }
                Err(e) => {
                    if first_error.as_ref().is_none_or(|(j, _)| i < *j) {
                        first_error = Some((i, e));
                    }
                }
            }
        }
        if let Some((i, e)) = first_error {
            let el = if i < self.root.images.len() {
                self.image_element(i)
            } else {
                "image".into()
            };
            return Err(self.err(el, e));
        }
        // Each image's pixels move into its first scene image; an image used both as colour
        // and as data gets a copy (they upload to different formats).
        for (k, &src) in self.image_sources.iter().enumerate() {
            let d = match self.image_sources[k + 1..].contains(&src) {
                true => decoded.get(&src).cloned(),
                false => decoded.remove(&src),
            }
            .ok_or_else(|| self.err(self.image_element(src), "was not decoded"))?;
            let data = &mut self.scene.images[k];
            data.width = d.width;
            data.height = d.height;
            data.rgba8 = d.rgba8;
            data.mips = d.mips;
            data.ktx2 = match self.opts.texture_format {
                // Kept for the upload: a block format, or RGBA8 once the device chose it.
                TextureFormat::Auto | TextureFormat::Block => d.ktx2,
                TextureFormat::Rgba8 => None,
            };
        }
        Ok(())
    }
}
