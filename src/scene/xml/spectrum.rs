//! `<spectrum>` property values and their RGB, as Mitsuba 3.9.1's RGB variants compute it
//! (`Properties::Spectrum` in `src/core/properties.cpp`, `spectrum_list_to_srgb` in `src/core/spectrum.cpp`).
//!
//! - `value="0.5"`: a uniform spectrum. As a reflectance (or any non-emissive parameter) it is the grey
//!   0.5; as an emitter's `radiance`/`intensity`/`irradiance` it is `0.5 * xyz_to_srgb(1, 1, 1)`
//!   = 0.5 * (1.2048, 0.9483, 0.9089): a flat spectrum is not white under sRGB's D65 white point, and the
//!   RGB variants reproduce what the spectral ones render.
//! - `value="400:0.34, 404:0.44, ..."`: wavelength (nm) : value pairs, wavelengths strictly increasing, at
//!   least two. Mitsuba integrates the piecewise-linear spectrum against the CIE 1931 matching functions
//!   at 1000 equally spaced wavelengths over [360, 830] nm (those outside the given range count as zero),
//!   times the D65 illuminant for non-emissive parameters (so a flat reflectance of 1 is white) and not for
//!   emitters; then XYZ -> linear sRGB. Reflectances are clamped to [0, 1], emission and unbounded
//!   parameters (`eta`, `k`, `alpha`...) only to >= 0.
//! - `filename="..."` (a spectrum file) and spectrum plugins (`<spectrum type="blackbody">`) are refused
//!   by the caller: the second is what Mitsuba's RGB variants refuse too (blackbody evaluation throws
//!   "Not implemented for non-spectral modes").
use super::cie::{CIE1931_X, CIE1931_Y, CIE1931_Z, CIE_MAX, CIE_MIN, CIE_SAMPLES, D65};
use glam::DVec3;

/// `MI_CIE_Y_NORMALIZATION`: a unit spectrum integrates to luminance 1.
#[allow(clippy::excessive_precision)]
const CIE_Y_NORMALIZATION: f64 = 1.0 / 106.7502593994140625;
/// `MI_CIE_D65_NORMALIZATION`: D65 integrates to luminance 1.
const CIE_D65_NORMALIZATION: f64 = 1.0 / 98.99741751876255;
/// Wavelengths at which Mitsuba samples a spectrum for the conversion.
const STEPS: usize = 1000;

/// A spectrum property: uniform (`wavelengths` empty, one value) or wavelength:value pairs.
#[derive(Debug, Clone, PartialEq)]
pub struct Spectrum {
    /// Strictly increasing wavelengths in nm; empty for a uniform spectrum.
    pub wavelengths: Vec<f64>,
    pub values: Vec<f64>,
}

/// How a plugin reads a colour parameter (Mitsuba's `get_texture`, `get_unbounded_texture`,
/// `get_emissive_texture`); it decides how a spectrum becomes RGB.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SpectrumUse {
    /// Reflectances and every other bounded parameter: D65-weighted, clamped to [0, 1].
    Reflectance,
    /// Unbounded non-emissive parameters (`eta`, `k`, `alpha`, ...): D65-weighted, clamped to >= 0.
    Unbounded,
    /// Emitters' `radiance`, `intensity`, `irradiance`: no D65 weight, clamped to >= 0.
    Emission,
}

impl SpectrumUse {
    /// The use of property `name` of an object of element `class` (e.g. "emitter") in Mitsuba 3.9.1's
    /// plugins.
    pub fn of(class: &str, name: &str) -> SpectrumUse {
        match name {
            "radiance" | "intensity" | "irradiance" if class == "emitter" => SpectrumUse::Emission,
            "eta" | "k" | "alpha" | "alpha_u" | "alpha_v" | "sigma_a" | "theta" | "delta" => SpectrumUse::Unbounded,
            _ => SpectrumUse::Reflectance,
        }
    }
}

impl Spectrum {
    /// Parses a `value` attribute: one number, or `wavelength:value` pairs separated by commas and/or
    /// whitespace. Errors (a message naming the offending token) as Mitsuba's `Properties::Spectrum`.
    pub fn parse(text: &str) -> Result<Spectrum, String> {
        let tokens: Vec<&str> = text.split(|c: char| c == ',' || c.is_whitespace()).filter(|t| !t.is_empty()).collect();
        let num = |t: &str, what: &str| t.trim().parse::<f64>().map_err(|_| format!("could not parse {what} \"{t}\""));
        if tokens.len() == 1 && !tokens[0].contains(':') {
            return Ok(Spectrum { wavelengths: Vec::new(), values: vec![num(tokens[0], "uniform spectrum value")?] });
        }
        let mut wavelengths = Vec::with_capacity(tokens.len());
        let mut values = Vec::with_capacity(tokens.len());
        for t in &tokens {
            let pair: Vec<&str> = t.split(':').filter(|s| !s.is_empty()).collect();
            if pair.len() != 2 {
                return Err(format!("invalid spectrum value \"{t}\" (expected wavelength:value pairs)"));
            }
            wavelengths.push(num(pair[0], "wavelength")?);
            values.push(num(pair[1], "spectrum value")?);
        }
        if wavelengths.len() < 2 {
            return Err("a spectrum needs a single value or at least two wavelength:value pairs".into());
        }
        if let Some(v) = wavelengths.iter().chain(&values).find(|v| !v.is_finite()) {
            return Err(format!("non-finite number {v} in a spectrum"));
        }
        if let Some(i) = (1..wavelengths.len()).find(|&i| wavelengths[i] <= wavelengths[i - 1]) {
            return Err(format!("wavelengths must be strictly increasing ({} nm follows {} nm)", wavelengths[i], wavelengths[i - 1]));
        }
        Ok(Spectrum { wavelengths, values })
    }

    /// A uniform spectrum's value.
    pub fn uniform(&self) -> Option<f64> {
        self.wavelengths.is_empty().then(|| self.values[0])
    }

    /// Linear sRGB as Mitsuba's RGB variants use this spectrum for a parameter read as `usage`.
    pub fn to_rgb(&self, usage: SpectrumUse) -> DVec3 {
        if let Some(v) = self.uniform() {
            return match usage {
                SpectrumUse::Emission => v * xyz_to_srgb(DVec3::ONE),
                _ => DVec3::splat(v),
            };
        }
        let d65 = usage != SpectrumUse::Emission;
        let rgb = xyz_to_srgb(self.xyz(d65));
        match usage {
            SpectrumUse::Reflectance => rgb.clamp(DVec3::ZERO, DVec3::ONE),
            _ => rgb.max(DVec3::ZERO),
        }
    }

    /// CIE XYZ of the piecewise-linear spectrum (times D65 if `d65`), Mitsuba's 1000-point rule.
    fn xyz(&self, d65: bool) -> DVec3 {
        let (w, v) = (&self.wavelengths, &self.values);
        let (first, last) = (w[0], w[w.len() - 1]);
        let mut xyz = DVec3::ZERO;
        for i in 0..STEPS {
            let x = CIE_MIN + (i as f64 / (STEPS - 1) as f64) * (CIE_MAX - CIE_MIN);
            if x < first || x > last {
                continue;
            }
            // Largest interval start <= x, within [0, n - 2].
            let k = w.partition_point(|&wk| wk <= x).saturating_sub(1).min(w.len() - 2);
            let (w0, w1, v0, v1) = (w[k], w[k + 1], v[k], v[k + 1]);
            let value = ((x - w1) * v0 + (w0 - x) * v1) / (w0 - w1);
            let weight = if d65 { table(&D65, x) * CIE_D65_NORMALIZATION } else { 1.0 };
            xyz += DVec3::new(table(&CIE1931_X, x), table(&CIE1931_Y, x), table(&CIE1931_Z, x)) * value * weight;
        }
        xyz * ((CIE_MAX - CIE_MIN) * CIE_Y_NORMALIZATION / STEPS as f64)
    }
}

/// A 5 nm table linearly interpolated at `x` nm (zero outside [360, 830]).
fn table(t: &[f32; CIE_SAMPLES], x: f64) -> f64 {
    if !(CIE_MIN..=CIE_MAX).contains(&x) {
        return 0.0;
    }
    let s = (x - CIE_MIN) * ((CIE_SAMPLES - 1) as f64 / (CIE_MAX - CIE_MIN));
    let i0 = (s as usize).min(CIE_SAMPLES - 2);
    let w1 = s - i0 as f64;
    (1.0 - w1) * t[i0] as f64 + w1 * t[i0 + 1] as f64
}

/// CIE XYZ to linear sRGB (Rec. 709 primaries, D65 white), with Mitsuba's f32 coefficients.
pub fn xyz_to_srgb(xyz: DVec3) -> DVec3 {
    #[allow(clippy::excessive_precision)]
    const M: [[f32; 3]; 3] = [[3.240479, -1.537150, -0.498535], [-0.969256, 1.875991, 0.041556], [0.055648, -0.204043, 1.057311]];
    let row = |r: [f32; 3]| r[0] as f64 * xyz.x + r[1] as f64 * xyz.y + r[2] as f64 * xyz.z;
    DVec3::new(row(M[0]), row(M[1]), row(M[2]))
}

#[cfg(test)]
mod tests;
