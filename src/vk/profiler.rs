use std::sync::Arc;

use ash::vk;

use super::context::Shared;
use super::{CallExt, Context, VkError, VkResult};

/// GPU timestamp scopes: `begin(name)`/`end` pairs recorded into command buffers, read back
/// as milliseconds (using the device's `timestampPeriod`).
///
/// On lavapipe the "GPU" is the CPU: durations are CPU time spent executing the commands.
pub struct GpuProfiler {
    shared: Arc<Shared>,
    pool: vk::QueryPool,
    capacity: u32,
    period_ns: f64,
    scopes: Vec<(String, u32)>,
    open: Option<usize>,
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
        })
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
    }

    /// Opens scope `name` (scopes do not nest: an open scope is closed first).
    pub fn begin(&mut self, cmd: vk::CommandBuffer, name: &str) {
        if self.open.is_some() {
            self.end(cmd);
        }
        let query = self.scopes.len() as u32 * 2;
        if query + 1 >= self.capacity {
            log::warn!("GPU profiler full: scope '{name}' not timed");
            return;
        }
        // SAFETY: query index within the pool, which was reset this frame.
        unsafe {
            self.shared.device.cmd_write_timestamp2(
                cmd,
                vk::PipelineStageFlags2::ALL_COMMANDS,
                self.pool,
                query,
            )
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
            let query = self.scopes[i].1 + 1;
            // SAFETY: as in `begin`.
            unsafe {
                self.shared.device.cmd_write_timestamp2(
                    cmd,
                    vk::PipelineStageFlags2::ALL_COMMANDS,
                    self.pool,
                    query,
                )
            };
        }
    }

    /// Milliseconds per scope, in recording order. Call after the submission completed.
    pub fn results(&self) -> VkResult<Vec<(String, f64)>> {
        if self.scopes.is_empty() {
            return Ok(Vec::new());
        }
        let mut raw = vec![0u64; self.scopes.len() * 2];
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
        Ok(self
            .scopes
            .iter()
            .map(|(name, q)| {
                let (a, b) = (raw[*q as usize], raw[*q as usize + 1]);
                (
                    name.clone(),
                    b.saturating_sub(a) as f64 * self.period_ns / 1e6,
                )
            })
            .collect())
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
