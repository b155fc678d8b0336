//! The decoder's output, shared by the image formats decoded by the `image` crate
//! ([`super::image`]) and by KTX2 ([`super::ktx2`]).

/// A decoded image: RGBA8 texels with row 0 at the top.
#[derive(Clone, Debug)]
pub(crate) struct Decoded {
    pub width: u32,
    pub height: u32,
    /// Level 0.
    pub rgba8: Vec<u8>,
    /// Levels 1.. as the file stores them (KTX2); empty: rqr generates the chain.
    pub mips: Vec<Vec<u8>>,
    /// The KTX2 file the levels were transcoded from (see [`super::ImageData::ktx2`]).
    pub ktx2: Option<std::sync::Arc<[u8]>>,
}
