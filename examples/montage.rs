//! Puts equally sized PNGs side by side with their file stems as labels:
//! `cargo run --example montage -- out.png a.png b.png ...` (used for README pictures).
fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (out, inputs) = args
        .split_first()
        .ok_or_else(|| anyhow::anyhow!("usage: montage OUT.png IN.png..."))?;
    let images: Vec<(String, image::RgbaImage)> = inputs
        .iter()
        .map(|p| {
            let stem = std::path::Path::new(p)
                .file_stem()
                .unwrap()
                .to_string_lossy()
                .to_uppercase();
            Ok((stem, image::open(p)?.to_rgba8()))
        })
        .collect::<anyhow::Result<_>>()?;
    let (w, h) = images[0].1.dimensions();
    let panels: Vec<(&str, &[u8], usize)> = images
        .iter()
        .map(|(n, i)| (n.as_str(), i.as_raw().as_slice(), 4))
        .collect();
    let c = rqr::render::image::label::side_by_side(w, h, &panels);
    image::RgbImage::from_raw(c.width, c.height, c.rgb)
        .unwrap()
        .save(out)?;
    Ok(())
}
