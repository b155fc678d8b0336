//! Image utilities on the host: PNG/EXR output, tonemapping, labelled side-by-sides and charts, and image
//! metrics (FLIP, PSNR).

pub mod label;
pub mod metrics;
pub mod output;
pub mod tonemap;
