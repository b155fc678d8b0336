//! Burst timing: frames of one or more [`FrameTargets`] recorded back to back,
//! alternating between the targets frame by frame, into as few submissions as the fence
//! timeout allows, after a warm-up that runs until two consecutive bursts agree.
//!
//! Why: a GPU drops its clock in any host gap between frames (an H200 idles at 345 MHz and
//! boosts to 1980 MHz), so frames submitted one by one with readbacks and file writes between
//! them are timed at whatever clock the gap left. Frames recorded back to back keep it up;
//! alternating the paths frame by frame makes a machine whose speed drifts (lavapipe on shared
//! CPU cores) slow every path alike.

use serde::Serialize;

use crate::render::drivers::targets::FrameTargets;
use crate::render::RenderOutput;
use crate::scene::Camera;
use crate::vk::{Context, FrameTiming, GpuProfiler};

/// Warm-up ends when two consecutive bursts' mean frame times differ by at most this share,
/// for every target.
pub const WARM_UP_TOLERANCE: f64 = 0.03;
/// Warm-up gives up (and the report says so) after this many bursts.
pub const WARM_UP_MAX_BURSTS: u32 = 8;

/// Whether two consecutive warm-up bursts agree: every mean frame time (one per target) within
/// [`WARM_UP_TOLERANCE`] of the other burst's.
pub fn bursts_agree(previous: &[f64], last: &[f64]) -> bool {
    previous.len() == last.len()
        && previous
            .iter()
            .zip(last)
            .all(|(a, b)| (a - b).abs() <= WARM_UP_TOLERANCE * a.max(*b))
}

/// How the frames were timed, for reports.
#[derive(Clone, Debug, Default, Serialize)]
pub struct BurstReport {
    /// Timed frames per target.
    pub frames: u32,
    /// Submissions the timed frames took (1 unless the fence timeout forced a split).
    pub submissions: u32,
    /// Warm-up bursts before timing.
    pub warm_up_bursts: u32,
    /// Frames per target in each warm-up burst.
    pub warm_up_frames: u32,
    /// Whether the last two warm-up bursts agreed within [`WARM_UP_TOLERANCE`].
    pub warm_up_settled: bool,
    /// Per warm-up burst, per target: mean GPU ms per frame.
    pub warm_up_mean_ms: Vec<Vec<f64>>,
    /// GPU milliseconds of every frame run (warm-up and timed, all targets): the work the
    /// wall time is compared with.
    pub gpu_ms_all_frames: f64,
}

/// The timed frames of every target, and its last frame's image and counts.
pub struct BurstResult {
    /// Per target: the timed frames in order.
    pub frames: Vec<Vec<FrameTiming>>,
    /// Per target: the output of its last timed frame (GPU times left empty).
    pub outputs: Vec<RenderOutput>,
    /// How the timing went.
    pub report: BurstReport,
}

/// Times `repeat` frames of each of `targets`, all through `camera`, after a warm-up (see the
/// module docs). Submissions are split only when their estimated GPU time would exceed
/// `max_submission_ms` (a share of the fence timeout), judged from the warm-up.
pub fn time_alternating(
    ctx: &Context,
    targets: &[&FrameTargets],
    camera: &Camera,
    repeat: u32,
    max_submission_ms: f64,
) -> crate::Result<BurstResult> {
    let repeat = repeat.max(1);
    let frames: Vec<_> = targets.iter().map(|t| t.gpu_frame(camera)).collect();
    let scopes: u32 = targets.iter().map(|t| t.scopes_per_frame()).sum();
    let mut report = BurstReport {
        frames: repeat,
        warm_up_frames: repeat.min(3),
        ..Default::default()
    };
    // Burst of `n` frames per target in one submission; the last round reads back.
    let burst = |n: u32,
                 profiler: &mut Option<GpuProfiler>,
                 read: bool|
     -> crate::Result<Vec<Vec<FrameTiming>>> {
        ctx.run("timed frames", |cmd| {
            if let Some(p) = profiler.as_mut() {
                p.reset(cmd);
            }
            for round in 0..n {
                for (t, frame) in targets.iter().zip(&frames) {
                    if let Some(p) = profiler.as_mut() {
                        p.begin_frame(cmd);
                    }
                    let out = (read && round + 1 == n).then(|| (t.readback_ring(), 0));
                    t.record(ctx, cmd, frame, profiler.as_mut(), out);
                    if let Some(p) = profiler.as_mut() {
                        p.end_frame(cmd);
                    }
                }
            }
            Ok(())
        })?;
        let timings = match profiler.as_ref() {
            Some(p) => p.frame_results()?,
            None => Vec::new(),
        };
        // Per target, in order (frames alternate between targets).
        let mut per_target = vec![Vec::new(); targets.len()];
        for (i, t) in timings.into_iter().enumerate() {
            per_target[i % targets.len()].push(t);
        }
        Ok(per_target)
    };
    let mean =
        |f: &[FrameTiming]| f.iter().map(|t| t.total_ms).sum::<f64>() / f.len().max(1) as f64;
    let mut warm_profiler = GpuProfiler::new(ctx, scopes * report.warm_up_frames).ok();
    let mut last: Option<Vec<f64>> = None;
    while report.warm_up_bursts < WARM_UP_MAX_BURSTS {
        let timed = burst(report.warm_up_frames, &mut warm_profiler, false)?;
        report.warm_up_bursts += 1;
        let means: Vec<f64> = timed.iter().map(|f| mean(f)).collect();
        report.gpu_ms_all_frames += timed.iter().flatten().map(|t| t.total_ms).sum::<f64>();
        report.warm_up_mean_ms.push(means.clone());
        if warm_profiler.is_none() {
            // No timestamps: nothing to settle.
            break;
        }
        if last
            .as_deref()
            .is_some_and(|prev| bursts_agree(prev, &means))
        {
            report.warm_up_settled = true;
            break;
        }
        last = Some(means);
    }
    drop(warm_profiler);
    // Split the timed frames only as far as the fence timeout needs.
    let round_ms: f64 = last
        .as_deref()
        .or(report.warm_up_mean_ms.last().map(Vec::as_slice))
        .map_or(0.0, |m| m.iter().sum());
    let per_submission = if round_ms > 0.0 {
        ((max_submission_ms / round_ms).floor() as u32).clamp(1, repeat)
    } else {
        repeat
    };
    let mut profiler = GpuProfiler::new(ctx, scopes * per_submission).ok();
    let mut timed: Vec<Vec<FrameTiming>> = vec![Vec::new(); targets.len()];
    let mut done = 0;
    while done < repeat {
        let n = per_submission.min(repeat - done);
        let part = burst(n, &mut profiler, done + n == repeat)?;
        report.submissions += 1;
        for (all, p) in timed.iter_mut().zip(part) {
            all.extend(p);
        }
        done += n;
    }
    report.gpu_ms_all_frames += timed.iter().flatten().map(|t| t.total_ms).sum::<f64>();
    let outputs = targets
        .iter()
        .map(|t| t.read())
        .collect::<Result<Vec<_>, _>>()?;
    Ok(BurstResult {
        frames: timed,
        outputs,
        report,
    })
}
