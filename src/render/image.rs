//! An RGB8 image, PNG encoding and decoding, and atomic file writes.

use std::io::Cursor;
use std::path::Path;

use crate::error::{Error, Result};

/// An 8-bit sRGB image, rows top to bottom, three bytes (R, G, B) per pixel.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `3 · width · height` bytes.
    pub pixels: Vec<u8>,
}

impl Image {
    /// An image filled with one colour.
    pub fn new(width: u32, height: u32, fill: [u8; 3]) -> Self {
        let n = width as usize * height as usize;
        let mut pixels = Vec::with_capacity(3 * n);
        for _ in 0..n {
            pixels.extend_from_slice(&fill);
        }
        Image {
            width,
            height,
            pixels,
        }
    }

    /// The colour at (x, y); (0, 0) is the top-left corner. Panics outside the image.
    pub fn pixel(&self, x: u32, y: u32) -> [u8; 3] {
        assert!(
            x < self.width && y < self.height,
            "pixel ({x}, {y}) outside"
        );
        let i = 3 * (y as usize * self.width as usize + x as usize);
        [self.pixels[i], self.pixels[i + 1], self.pixels[i + 2]]
    }

    /// Set the colour at (x, y). Panics outside the image.
    pub fn set_pixel(&mut self, x: u32, y: u32, colour: [u8; 3]) {
        assert!(
            x < self.width && y < self.height,
            "pixel ({x}, {y}) outside"
        );
        let i = 3 * (y as usize * self.width as usize + x as usize);
        self.pixels[i..i + 3].copy_from_slice(&colour);
    }

    /// Mix `colour` over the pixel at (x, y) with opacity `alpha` in [0, 1]; coordinates
    /// outside the image are ignored (so shapes may cross the border).
    pub fn blend_pixel(&mut self, x: i64, y: i64, colour: [u8; 3], alpha: f32) {
        if x < 0 || y < 0 || x >= self.width as i64 || y >= self.height as i64 {
            return;
        }
        let a = alpha.clamp(0.0, 1.0);
        if a <= 0.0 {
            return;
        }
        let i = 3 * (y as usize * self.width as usize + x as usize);
        for (p, &c) in self.pixels[i..i + 3].iter_mut().zip(&colour) {
            let old = *p as f32;
            *p = (old + (c as f32 - old) * a).round() as u8;
        }
    }

    /// The image as PNG bytes (RGB, 8 bits, deterministic).
    pub fn encode_png(&self) -> Vec<u8> {
        let mut out = Vec::new();
        let mut encoder = png::Encoder::new(&mut out, self.width, self.height);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.set_compression(png::Compression::Balanced);
        // Writing into a Vec cannot fail, and the header and data sizes agree by construction.
        let mut writer = encoder
            .write_header()
            .expect("PNG header into memory cannot fail");
        writer
            .write_image_data(&self.pixels)
            .expect("PNG data of the declared size into memory cannot fail");
        writer.finish().expect("PNG end into memory cannot fail");
        out
    }

    /// Decode an 8-bit RGB or RGBA PNG (alpha is dropped); other formats are an error.
    pub fn decode_png(bytes: &[u8]) -> Result<Image> {
        let fail = |message: String| Error::parse("<png>", None, message);
        let decoder = png::Decoder::new(Cursor::new(bytes));
        let mut reader = decoder.read_info().map_err(|e| fail(e.to_string()))?;
        let size = reader
            .output_buffer_size()
            .ok_or_else(|| fail("image too large".into()))?;
        let mut buf = vec![0; size];
        let info = reader
            .next_frame(&mut buf)
            .map_err(|e| fail(e.to_string()))?;
        if info.bit_depth != png::BitDepth::Eight {
            return Err(fail(format!("{:?} bits per channel", info.bit_depth)));
        }
        let channels = match info.color_type {
            png::ColorType::Rgb => 3,
            png::ColorType::Rgba => 4,
            other => return Err(fail(format!("colour type {other:?}"))),
        };
        let mut pixels = Vec::with_capacity(3 * (info.width * info.height) as usize);
        for row in buf.chunks(info.line_size).take(info.height as usize) {
            for px in row[..channels * info.width as usize].chunks(channels) {
                pixels.extend_from_slice(&px[..3]);
            }
        }
        Ok(Image {
            width: info.width,
            height: info.height,
            pixels,
        })
    }

    /// Write the image as a PNG file, atomically: a reader never sees a half-written file.
    pub fn write_png(&self, path: impl AsRef<Path>) -> Result<()> {
        write_atomic(path.as_ref(), &self.encode_png())
    }
}

/// Write `bytes` to `path` atomically (temp file beside it, then rename).
pub(crate) fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    crate::io::atomic_write(path, |w| w.write_all(bytes))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn png_round_trip() {
        let mut img = Image::new(5, 3, [10, 20, 30]);
        img.set_pixel(4, 2, [255, 0, 7]);
        img.blend_pixel(0, 0, [110, 120, 130], 0.5);
        img.blend_pixel(-1, 9, [0, 0, 0], 1.0);
        let back = Image::decode_png(&img.encode_png()).unwrap();
        assert_eq!(back, img);
        assert_eq!(back.pixel(0, 0), [60, 70, 80]);
    }
}
