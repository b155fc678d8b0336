//! Image utilities on the host: PNG/EXR output, labelled side-by-sides and charts, and image
//! metrics (FLIP, PSNR).

pub mod compare;
pub mod label;
pub mod output;
