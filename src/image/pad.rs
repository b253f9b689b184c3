//! Mitsuba 3.9.1's `Bitmap::pad_to(min_size)`: grows a bitmap to at least `min_width x min_height` by
//! replicating its last column to the right and then its last row downwards.
//!
//! Mitsuba applies it to every environment map (`envmap`: at least 2 x 3 texels, so that a 1x1 or 7x1
//! map has rows to interpolate between) and to bitmap textures smaller than 2 in either direction
//! (replication there changes no lookup, so textures are left as they are).

/// Returns (width, height, texels) padded to at least `min_width x min_height` (unchanged when already
/// that large). `texels` is row-major with `width * height` entries (not checked here: callers hold
/// images whose size was validated by the reader).
pub fn pad_to<T: Copy>(width: u32, height: u32, texels: Vec<T>, min_width: u32, min_height: u32) -> (u32, u32, Vec<T>) {
    let (nw, nh) = (width.max(min_width), height.max(min_height));
    if (nw, nh) == (width, height) || width == 0 || height == 0 {
        return (width, height, texels);
    }
    let (w, nwu) = (width as usize, nw as usize);
    let mut out = Vec::with_capacity(nwu * nh as usize);
    for row in texels.chunks(w).take(height as usize) {
        out.extend_from_slice(row);
        let last = row[w - 1];
        out.extend(std::iter::repeat_n(last, nwu - w));
    }
    let last_row = out[out.len() - nwu..].to_vec();
    for _ in height..nh {
        out.extend_from_slice(&last_row);
    }
    (nw, nh, out)
}

#[cfg(test)]
mod tests;
