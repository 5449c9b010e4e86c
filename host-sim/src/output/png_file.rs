//! PNG figures: plotters draws into an RGB buffer and the `png` crate writes it, with the
//! settings of `image`'s default PNG encoder (fast compression, adaptive filtering starting
//! from `Sub`), so that the files are the bytes plotters' own `bitmap_encoder` would write,
//! without building `image` and its decoders.

use anyhow::{anyhow, Context, Result};
use plotters::coord::Shift;
use plotters::prelude::{BitMapBackend, DrawingArea, IntoDrawingArea};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

/// Draw a `size` (width, height in pixels) figure with `draw` on a blank (black) canvas,
/// as plotters' bitmap backend starts, and write it to `path` as an 8-bit RGB PNG.
pub fn write<F>(path: &Path, size: (u32, u32), draw: F) -> Result<()>
where
    F: FnOnce(&DrawingArea<BitMapBackend<'_>, Shift>) -> Result<()>,
{
    let (w, h) = size;
    let mut rgb = vec![0u8; w as usize * h as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, size).into_drawing_area();
        draw(&root)?;
        root.present()
            .map_err(|x| anyhow!("{}: {x}", path.display()))?;
    }
    encode(path, &rgb, size)
}

/// Write `rgb` (row-major 8-bit RGB, `size` pixels) to `path` as a PNG.
pub fn encode(path: &Path, rgb: &[u8], size: (u32, u32)) -> Result<()> {
    let file = File::create(path).with_context(|| format!("creating {}", path.display()))?;
    let mut out = BufWriter::new(file);
    let mut encoder = png::Encoder::new(&mut out, size.0, size.1);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_compression(png::Compression::Fast);
    encoder.set_filter(png::FilterType::Sub);
    encoder.set_adaptive_filter(png::AdaptiveFilterType::Adaptive);
    let e = |x: png::EncodingError| anyhow!("{}: {x}", path.display());
    let mut writer = encoder.write_header().map_err(e)?;
    writer.write_image_data(rgb).map_err(e)?;
    writer.finish().map_err(e)?;
    out.flush()
        .with_context(|| format!("writing {}", path.display()))
}
