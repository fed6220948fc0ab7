//! Animated GIFs: one global palette for all frames (median cut on a 6-bit-per-channel
//! histogram), ordered dithering (stable from frame to frame, unlike error diffusion, so the
//! still background does not crawl), and frame differencing (unchanged pixels transparent, each
//! frame cropped to what changed) to keep files small. Deterministic.

use std::borrow::Cow;
use std::path::Path;

use super::image::{Image, write_atomic};
use crate::error::{Error, Result};

/// Palette entries for colours; entry 255 is reserved for "unchanged" (transparent).
const COLOURS: usize = 255;
const TRANSPARENT: u8 = 255;
/// Histogram resolution per channel.
const BITS: u32 = 6;
const SIDE: usize = 1 << BITS;
/// Peak-to-peak amplitude of the ordered dither, in 8-bit levels.
const DITHER: f32 = 10.0;
/// Pixels sampled for the palette at most (the rest is strided).
const SAMPLE_BUDGET: usize = 4_000_000;

/// 4×4 Bayer matrix, values 0..16.
const BAYER: [[u8; 4]; 4] = [[0, 8, 2, 10], [12, 4, 14, 6], [3, 11, 1, 9], [15, 7, 13, 5]];

/// Encode `frames` (all the same size) as a looping GIF with `delay_cs` hundredths of a second
/// per frame.
pub fn encode_gif(frames: &[Image], delay_cs: u16) -> Result<Vec<u8>> {
    let first = frames
        .first()
        .ok_or_else(|| Error::parameter("output.gif", "no frames to animate"))?;
    let (w, h) = (first.width, first.height);
    let mut histogram = Histogram::new(frames.len(), w, h)?;
    for f in frames {
        histogram.add(f)?;
    }
    let mut out = Vec::new();
    let mut stream = GifStream::new(&mut out, &histogram.palette(), w, h, delay_cs)?;
    for f in frames {
        stream.push(f)?;
    }
    drop(stream);
    Ok(out)
}

/// Write `frames` as a looping GIF at `path`, atomically (temp file + rename).
pub fn write_gif(path: impl AsRef<Path>, frames: &[Image], delay_cs: u16) -> Result<()> {
    write_atomic(path.as_ref(), &encode_gif(frames, delay_cs)?)
}

/// The colour histogram of a GIF's frames, added one at a time (the first pass of a streamed
/// GIF: the palette must be known before the first frame is written). Samples every k-th pixel
/// of each frame, k set by the total so at most [`SAMPLE_BUDGET`] are counted.
pub struct Histogram {
    count: Vec<u64>,
    sums: Vec<[u64; 3]>,
    stride: usize,
    size: (u32, u32),
}

impl Histogram {
    /// For `frames` frames of `width`×`height` pixels.
    pub fn new(frames: usize, width: u32, height: u32) -> Result<Self> {
        check_size(width, height)?;
        let total = frames * width as usize * height as usize;
        Ok(Histogram {
            count: vec![0u64; SIDE * SIDE * SIDE],
            sums: vec![[0u64; 3]; SIDE * SIDE * SIDE],
            stride: total.div_ceil(SAMPLE_BUDGET).max(1),
            size: (width, height),
        })
    }

    /// Count one frame's sampled pixels.
    pub fn add(&mut self, img: &Image) -> Result<()> {
        same_size(self.size, img)?;
        for px in img.pixels.chunks_exact(3).step_by(self.stride) {
            let k = key([px[0], px[1], px[2]]);
            self.count[k] += 1;
            for (sum, &c) in self.sums[k].iter_mut().zip(px) {
                *sum += c as u64;
            }
        }
        Ok(())
    }

    /// The median-cut palette of what was counted.
    pub fn palette(&self) -> GifPalette {
        GifPalette(Palette::median_cut(&self.count, &self.sums))
    }
}

/// A GIF's global palette (see [`Histogram::palette`]).
pub struct GifPalette(Palette);

/// A looping GIF written frame by frame to `W` (the second pass of a streamed GIF): memory
/// holds one frame, whatever their number.
pub struct GifStream<W: std::io::Write> {
    encoder: gif::Encoder<W>,
    palette: Palette,
    lookup: Vec<u8>,
    looked_up: Vec<bool>,
    shown: Option<Vec<u8>>,
    size: (u32, u32),
    delay_cs: u16,
}

impl<W: std::io::Write> GifStream<W> {
    /// Start a GIF of `width`×`height` frames with `palette`, `delay_cs` hundredths of a second
    /// per frame.
    pub fn new(
        out: W,
        palette: &GifPalette,
        width: u32,
        height: u32,
        delay_cs: u16,
    ) -> Result<Self> {
        check_size(width, height)?;
        let palette = Palette {
            colours: palette.0.colours.clone(),
        };
        let mut flat = Vec::with_capacity(3 * 256);
        for c in &palette.colours {
            flat.extend_from_slice(c);
        }
        flat.resize(3 * 256, 0);
        let mut encoder = gif::Encoder::new(out, width as u16, height as u16, &flat)
            .map_err(|e| Error::parameter("output.gif", e.to_string()))?;
        encoder
            .set_repeat(gif::Repeat::Infinite)
            .map_err(|e| Error::parameter("output.gif", e.to_string()))?;
        Ok(GifStream {
            encoder,
            palette,
            lookup: vec![u8::MAX; SIDE * SIDE * SIDE],
            looked_up: vec![false; SIDE * SIDE * SIDE],
            shown: None,
            size: (width, height),
            delay_cs,
        })
    }

    /// Append one frame (only what changed since the last one is stored).
    pub fn push(&mut self, img: &Image) -> Result<()> {
        same_size(self.size, img)?;
        let (w, h) = self.size;
        let indices = self.palette.map(img, &mut self.lookup, &mut self.looked_up);
        let frame = match &self.shown {
            None => gif::Frame {
                width: w as u16,
                height: h as u16,
                buffer: Cow::Borrowed(&indices),
                delay: self.delay_cs,
                dispose: gif::DisposalMethod::Keep,
                ..gif::Frame::default()
            },
            Some(prev) => difference(prev, &indices, w as usize, h as usize, self.delay_cs),
        };
        self.encoder
            .write_frame(&frame)
            .map_err(|e| Error::parameter("output.gif", e.to_string()))?;
        self.shown = Some(indices);
        Ok(())
    }
}

fn check_size(w: u32, h: u32) -> Result<()> {
    if w == 0 || h == 0 || w > u16::MAX as u32 || h > u16::MAX as u32 {
        return Err(Error::parameter(
            "output.gif",
            format!("{w}x{h} pixels: GIF sides must lie in 1..=65535"),
        ));
    }
    Ok(())
}

fn same_size((w, h): (u32, u32), f: &Image) -> Result<()> {
    if (f.width, f.height) != (w, h) {
        return Err(Error::parameter(
            "output.gif",
            format!(
                "frames differ in size: {}x{} and {}x{}",
                w, h, f.width, f.height
            ),
        ));
    }
    Ok(())
}

/// The part of `next` that differs from `prev`, cropped, with unchanged pixels transparent.
fn difference(prev: &[u8], next: &[u8], w: usize, h: usize, delay: u16) -> gif::Frame<'static> {
    let (mut x0, mut y0, mut x1, mut y1) = (w, h, 0, 0);
    for y in 0..h {
        for x in 0..w {
            if prev[y * w + x] != next[y * w + x] {
                x0 = x0.min(x);
                x1 = x1.max(x);
                y0 = y0.min(y);
                y1 = y1.max(y);
            }
        }
    }
    if x0 > x1 {
        // Nothing changed: a single transparent pixel keeps the frame's delay.
        (x0, y0, x1, y1) = (0, 0, 0, 0);
    }
    let mut buffer = Vec::with_capacity((x1 - x0 + 1) * (y1 - y0 + 1));
    for y in y0..=y1 {
        for x in x0..=x1 {
            let i = y * w + x;
            buffer.push(if prev[i] == next[i] {
                TRANSPARENT
            } else {
                next[i]
            });
        }
    }
    gif::Frame {
        left: x0 as u16,
        top: y0 as u16,
        width: (x1 - x0 + 1) as u16,
        height: (y1 - y0 + 1) as u16,
        buffer: Cow::Owned(buffer),
        delay,
        dispose: gif::DisposalMethod::Keep,
        transparent: Some(TRANSPARENT),
        ..gif::Frame::default()
    }
}

/// A histogram bin that occurs: its key (r, g, b at 6 bits), pixel count and 8-bit sums.
#[derive(Clone, Copy)]
struct Bin {
    rgb: [u8; 3],
    count: u64,
    sums: [u64; 3],
}

struct Palette {
    colours: Vec<[u8; 3]>,
}

impl Palette {
    /// Median cut: start from one box holding every occurring bin; repeatedly split the box
    /// with the largest count × extent along its longest axis at its weighted median, until
    /// there are [`COLOURS`] boxes or none can be split. Each box's colour is its mean.
    fn median_cut(count: &[u64], sums: &[[u64; 3]]) -> Palette {
        let mut bins: Vec<Bin> = (0..count.len())
            .filter(|&k| count[k] > 0)
            .map(|k| Bin {
                rgb: [
                    (k >> (2 * BITS)) as u8,
                    ((k >> BITS) & (SIDE - 1)) as u8,
                    (k & (SIDE - 1)) as u8,
                ],
                count: count[k],
                sums: sums[k],
            })
            .collect();
        // Boxes are ranges of `bins`; splitting sorts a range along one channel.
        let mut boxes = vec![(0, bins.len())];
        while boxes.len() < COLOURS {
            let mut best: Option<(usize, usize, u64)> = None;
            for (b, &(lo, hi)) in boxes.iter().enumerate() {
                if hi - lo < 2 {
                    continue;
                }
                let (axis, extent) = longest_axis(&bins[lo..hi]);
                let weight: u64 = bins[lo..hi].iter().map(|b| b.count).sum();
                let score = weight * extent as u64;
                if score > 0 && best.is_none_or(|(_, _, s)| score > s) {
                    best = Some((b, axis, score));
                }
            }
            let Some((b, axis, _)) = best else { break };
            let (lo, hi) = boxes[b];
            let slice = &mut bins[lo..hi];
            slice.sort_unstable_by_key(|bin| (bin.rgb[axis], bin.rgb));
            let half: u64 = slice.iter().map(|b| b.count).sum::<u64>() / 2;
            let mut acc = 0;
            let mut cut = 1;
            for (i, bin) in slice.iter().enumerate() {
                acc += bin.count;
                if acc >= half {
                    cut = (i + 1).clamp(1, slice.len() - 1);
                    break;
                }
            }
            boxes[b] = (lo, lo + cut);
            boxes.push((lo + cut, hi));
        }
        let mut colours: Vec<[u8; 3]> = boxes
            .iter()
            .map(|&(lo, hi)| {
                let n: u64 = bins[lo..hi].iter().map(|b| b.count).sum::<u64>().max(1);
                std::array::from_fn(|c| {
                    let s: u64 = bins[lo..hi].iter().map(|b| b.sums[c]).sum();
                    ((s + n / 2) / n) as u8
                })
            })
            .collect();
        if colours.is_empty() {
            colours.push([0, 0, 0]);
        }
        Palette { colours }
    }

    /// Palette indices of `img`, ordered-dithered; `lookup` caches the nearest entry per bin.
    fn map(&self, img: &Image, lookup: &mut [u8], looked_up: &mut [bool]) -> Vec<u8> {
        let w = img.width as usize;
        let mut out = Vec::with_capacity(img.pixels.len() / 3);
        for (i, px) in img.pixels.chunks_exact(3).enumerate() {
            let (x, y) = (i % w, i / w);
            let offset = ((BAYER[y % 4][x % 4] as f32 + 0.5) / 16.0 - 0.5) * DITHER;
            let c: [u8; 3] =
                std::array::from_fn(|k| (px[k] as f32 + offset).round().clamp(0.0, 255.0) as u8);
            let k = key(c);
            if !looked_up[k] {
                lookup[k] = self.nearest(bin_centre(k));
                looked_up[k] = true;
            }
            out.push(lookup[k]);
        }
        out
    }

    fn nearest(&self, c: [i32; 3]) -> u8 {
        let mut best = (i32::MAX, 0);
        for (i, p) in self.colours.iter().enumerate() {
            // Weighted RGB distance (green matters most to the eye).
            let d = [2, 4, 3]
                .iter()
                .enumerate()
                .map(|(k, w)| w * (p[k] as i32 - c[k]).pow(2))
                .sum::<i32>();
            if d < best.0 {
                best = (d, i);
            }
        }
        best.1 as u8
    }
}

fn key(c: [u8; 3]) -> usize {
    let s = 8 - BITS;
    ((c[0] >> s) as usize) << (2 * BITS) | ((c[1] >> s) as usize) << BITS | (c[2] >> s) as usize
}

fn bin_centre(k: usize) -> [i32; 3] {
    let s = 8 - BITS;
    let half = 1 << (s - 1);
    [
        ((k >> (2 * BITS)) as i32) << s | half,
        (((k >> BITS) & (SIDE - 1)) as i32) << s | half,
        ((k & (SIDE - 1)) as i32) << s | half,
    ]
}

/// The channel along which the bins spread most, and that spread (in 6-bit steps).
fn longest_axis(bins: &[Bin]) -> (usize, u8) {
    let mut best = (0, 0);
    for axis in 0..3 {
        let lo = bins.iter().map(|b| b.rgb[axis]).min().unwrap_or(0);
        let hi = bins.iter().map(|b| b.rgb[axis]).max().unwrap_or(0);
        if hi - lo > best.1 {
            best = (axis, hi - lo);
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn few_colours_are_kept_exactly() {
        let mut img = Image::new(8, 8, [10, 200, 30]);
        img.set_pixel(3, 3, [250, 250, 250]);
        img.set_pixel(4, 4, [0, 0, 128]);
        let mut histogram = Histogram::new(1, 8, 8).unwrap();
        histogram.add(&img).unwrap();
        let palette = histogram.palette().0;
        for c in [[10, 200, 30], [250, 250, 250], [0, 0, 128]] {
            assert!(palette.colours.contains(&c), "{c:?} missing");
        }
    }

    #[test]
    fn mismatched_or_missing_frames_are_errors() {
        assert!(encode_gif(&[], 4).is_err());
        let a = Image::new(4, 4, [0, 0, 0]);
        let b = Image::new(5, 4, [0, 0, 0]);
        assert!(encode_gif(&[a, b], 4).is_err());
    }
}
