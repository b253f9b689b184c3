//! Roughplastic's precomputed tables, computed as Mitsuba 3.9.1 does in `RoughPlastic::parameters_changed`
//! (`src/bsdfs/roughplastic.cpp`, `eval_transmittance` / `eval_reflectance` in
//! `include/mitsuba/render/microfacet.h`):
//!
//! - `external_transmittance[k]`, k = 0..64: the directional-hemispherical transmittance of the rough
//!   dielectric interface (relative IOR `eta`) for `wi = (sqrt(1 - mu^2), 0, mu)`, `mu = max(1e-6, k / 63)`,
//!   integrated with a 32x32 (eta > 1) or 128x128 (eta <= 1) Gauss-Legendre rule over the visible-normal
//!   sampling domain (Heitz and d'Eon 2014; Beckmann via Jakob's numerical inversion, three Newton steps).
//! - `internal_reflectance = 2 mean_k(R(mu_k; 1/eta) mu_k)`, the reflectance seen from inside.
//!
//! Deviation: computed in f64 (Mitsuba: f32 packets), with `erf` from Abramowitz and Stegun 7.1.26
//! (|error| < 1.5e-7) and `erfinv` refined by Newton steps against it; the tables agree with Mitsuba's to
//! about 1e-6. Results are memoised per (distribution, alpha, eta) for the process lifetime.
use std::collections::HashMap;
use std::f64::consts::PI;
use std::sync::{Arc, OnceLock, RwLock};

/// Entries in the external transmittance table (Mitsuba's `MI_ROUGH_TRANSMITTANCE_RES`).
pub const TABLE_RES: usize = 64;

/// The precomputed values of one roughplastic parameter set.
#[derive(Debug, Clone, PartialEq)]
pub struct RoughPlasticTables {
    pub external_transmittance: [f32; TABLE_RES],
    pub internal_reflectance: f32,
}

/// Tables for (GGX or Beckmann, alpha, eta = int_ior / ext_ior), memoised.
pub fn roughplastic_tables(ggx: bool, alpha: f32, eta: f32) -> Arc<RoughPlasticTables> {
    type Memo = RwLock<HashMap<(bool, u32, u32), Arc<RoughPlasticTables>>>;
    static MEMO: OnceLock<Memo> = OnceLock::new();
    let memo = MEMO.get_or_init(|| RwLock::new(HashMap::new()));
    let key = (ggx, alpha.to_bits(), eta.to_bits());
    if let Some(t) = memo.read().unwrap_or_else(|e| e.into_inner()).get(&key) {
        return t.clone();
    }
    let t = Arc::new(compute(ggx, alpha, eta));
    memo.write().unwrap_or_else(|e| e.into_inner()).entry(key).or_insert(t).clone()
}

fn compute(ggx: bool, alpha: f32, eta: f32) -> RoughPlasticTables {
    let distr = Distr { ggx, alpha: (alpha as f64).max(1e-4) };
    let eta = eta as f64;
    let mut external_transmittance = [0f32; TABLE_RES];
    let mut internal_sum = 0.0;
    for (k, t) in external_transmittance.iter_mut().enumerate() {
        let mu = (k as f64 / (TABLE_RES - 1) as f64).max(1e-6);
        let wi = [(1.0 - mu * mu).sqrt(), 0.0, mu];
        *t = integrate(&distr, wi, eta, false) as f32;
        internal_sum += integrate(&distr, wi, 1.0 / eta, true) * mu;
    }
    RoughPlasticTables { external_transmittance, internal_reflectance: (internal_sum / TABLE_RES as f64 * 2.0) as f32 }
}

/// Mitsuba's `eval_transmittance` (reflect = false) or `eval_reflectance` (reflect = true) for one `wi`.
fn integrate(distr: &Distr, wi: [f64; 3], eta: f64, reflect: bool) -> f64 {
    let res = if eta > 1.0 { 32 } else { 128 };
    let (nodes, weights) = gauss_legendre(res);
    let mut sum = 0.0;
    for (ny, wy) in nodes.iter().zip(&weights) {
        for (nx, wx) in nodes.iter().zip(&weights) {
            let m = distr.sample_visible(wi, [nx * 0.5 + 0.5, ny * 0.5 + 0.5]);
            let cos_i = dot(wi, m);
            let (f, cos_t, _, eta_ti) = fresnel(cos_i, eta);
            let (wo, weight) = if reflect {
                ([2.0 * cos_i * m[0] - wi[0], 2.0 * cos_i * m[1] - wi[1], 2.0 * cos_i * m[2] - wi[2]], f)
            } else {
                // refract(wi, m, cos_theta_t, eta_ti) = m (cos_i eta_ti + cos_t) - wi eta_ti
                let s = cos_i * eta_ti + cos_t;
                ([m[0] * s - wi[0] * eta_ti, m[1] * s - wi[1] * eta_ti, m[2] * s - wi[2] * eta_ti], 1.0 - f)
            };
            let valid = if reflect { wo[2] > 0.0 && wi[2] > 0.0 } else { wo[2] * wi[2] < 0.0 };
            if valid {
                sum += distr.smith_g1(wo, m) * weight * wx * wy * 0.25;
            }
        }
    }
    sum
}

struct Distr {
    ggx: bool,
    alpha: f64,
}

impl Distr {
    fn smith_g1(&self, v: [f64; 3], m: [f64; 3]) -> f64 {
        let xy_alpha_2 = (self.alpha * v[0]).powi(2) + (self.alpha * v[1]).powi(2);
        let tan_theta_alpha_2 = xy_alpha_2 / (v[2] * v[2]);
        let mut g = if self.ggx {
            2.0 / (1.0 + (1.0 + tan_theta_alpha_2).sqrt())
        } else {
            let a = 1.0 / tan_theta_alpha_2.sqrt();
            if a >= 1.6 {
                1.0
            } else {
                (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a)
            }
        };
        if xy_alpha_2 == 0.0 {
            g = 1.0;
        }
        if dot(v, m) * v[2] <= 0.0 {
            g = 0.0;
        }
        g
    }

    /// Visible-normal sampling (`MicrofacetDistribution::sample` with `sample_visible`), isotropic.
    fn sample_visible(&self, wi: [f64; 3], u: [f64; 2]) -> [f64; 3] {
        let a = self.alpha;
        let wp = normalize([a * wi[0], a * wi[1], wi[2]]);
        let sin_theta_2 = wp[0] * wp[0] + wp[1] * wp[1];
        let (sin_phi, cos_phi) = if sin_theta_2 <= 4.0 * f32::EPSILON as f64 * 0.5 {
            (0.0, 1.0)
        } else {
            let r = 1.0 / sin_theta_2.sqrt();
            ((wp[1] * r).clamp(-1.0, 1.0), (wp[0] * r).clamp(-1.0, 1.0))
        };
        let s = self.sample_visible_11(wp[2], u);
        let sx = (cos_phi * s[0] - sin_phi * s[1]) * a;
        let sy = (sin_phi * s[0] + cos_phi * s[1]) * a;
        normalize([-sx, -sy, 1.0])
    }

    fn sample_visible_11(&self, cos_theta_i: f64, u: [f64; 2]) -> [f64; 2] {
        if self.ggx {
            let p = square_to_uniform_disk_concentric(u);
            let s = 0.5 * (1.0 + cos_theta_i);
            let (x, y0) = (p[0], p[1]);
            let y = (1.0 - x * x).max(0.0).sqrt() * (1.0 - s) + y0 * s;
            let z = (1.0 - x * x - y * y).max(0.0).sqrt();
            let sin_theta_i = (1.0 - cos_theta_i * cos_theta_i).max(0.0).sqrt();
            let norm = 1.0 / (sin_theta_i * y + cos_theta_i * z);
            [(cos_theta_i * y - sin_theta_i * z) * norm, x * norm]
        } else {
            let tan_theta_i = (1.0 - cos_theta_i * cos_theta_i).max(0.0).sqrt() / cos_theta_i;
            let cot_theta_i = 1.0 / tan_theta_i;
            let maxval = erf(cot_theta_i);
            let ux = u[0].clamp(1e-6, 1.0 - 1e-6);
            let uy = u[1].clamp(1e-6, 1.0 - 1e-6);
            let mut x = maxval - (maxval + 1.0) * erf((-ux.ln()).sqrt());
            let target = ux * (1.0 + maxval + tan_theta_i * (-cot_theta_i * cot_theta_i).exp() / PI.sqrt());
            for _ in 0..3 {
                let slope = erfinv(x);
                let value = 1.0 + x + tan_theta_i * (-slope * slope).exp() / PI.sqrt() - target;
                let derivative = 1.0 - slope * tan_theta_i;
                x -= value / derivative;
            }
            [erfinv(x), erfinv(2.0 * uy - 1.0)]
        }
    }
}

/// Mitsuba's `fresnel`: (reflectance, cos_theta_t, eta_it, eta_ti).
fn fresnel(cos_theta_i: f64, eta: f64) -> (f64, f64, f64, f64) {
    let outside = cos_theta_i >= 0.0;
    let (eta_it, eta_ti) = if outside { (eta, 1.0 / eta) } else { (1.0 / eta, eta) };
    let cos_theta_t_sqr = 1.0 - (1.0 - cos_theta_i * cos_theta_i) * eta_ti * eta_ti;
    let ci = cos_theta_i.abs();
    let ct = cos_theta_t_sqr.max(0.0).sqrt();
    let r = if eta == 1.0 {
        0.0
    } else if ci == 0.0 {
        1.0
    } else {
        let a_s = (ci - eta_it * ct) / (ci + eta_it * ct);
        let a_p = (ct - eta_it * ci) / (ct + eta_it * ci);
        0.5 * (a_s * a_s + a_p * a_p)
    };
    let cos_theta_t = if cos_theta_i >= 0.0 { -ct } else { ct };
    (r, cos_theta_t, eta_it, eta_ti)
}

fn square_to_uniform_disk_concentric(u: [f64; 2]) -> [f64; 2] {
    let (x, y) = (2.0 * u[0] - 1.0, 2.0 * u[1] - 1.0);
    if x == 0.0 && y == 0.0 {
        return [0.0, 0.0];
    }
    let q13 = x.abs() < y.abs();
    let (r, rp) = if q13 { (y, x) } else { (x, y) };
    let mut phi = 0.25 * PI * rp / r;
    if q13 {
        phi = 0.5 * PI - phi;
    }
    [r * phi.cos(), r * phi.sin()]
}

/// Gauss-Legendre nodes and weights on [-1, 1] (Newton iteration on P_n).
fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut nodes = vec![0.0; n];
    let mut weights = vec![0.0; n];
    for i in 0..n {
        let mut x = -(PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, x);
            for k in 2..=n {
                let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                p0 = p1;
                p1 = p2;
            }
            dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
            let dx = p1 / dp;
            x -= dx;
            if dx.abs() < 1e-15 {
                break;
            }
        }
        nodes[i] = x;
        weights[i] = 2.0 / ((1.0 - x * x) * dp * dp);
    }
    (nodes, weights)
}

/// Abramowitz and Stegun 7.1.26.
fn erf(x: f64) -> f64 {
    let t = 1.0 / (1.0 + 0.3275911 * x.abs());
    let poly = t * (0.254829592 + t * (-0.284496736 + t * (1.421413741 + t * (-1.453152027 + t * 1.061405429))));
    let y = 1.0 - poly * (-x * x).exp();
    if x < 0.0 {
        -y
    } else {
        y
    }
}

/// Inverse of `erf` above: Giles' approximation refined by Newton steps.
fn erfinv(y: f64) -> f64 {
    let y = y.clamp(-1.0 + 1e-15, 1.0 - 1e-15);
    let w = -((1.0 - y) * (1.0 + y)).ln();
    let mut x = if w < 5.0 {
        let w = w - 2.5;
        let mut p = 2.81022636e-08;
        for c in [3.43273939e-07, -3.5233877e-06, -4.39150654e-06, 0.00021858087, -0.00125372503, -0.00417768164, 0.246640727, 1.50140941] {
            p = c + p * w;
        }
        p * y
    } else {
        let w = w.sqrt() - 3.0;
        let mut p = -0.000200214257;
        for c in [0.000100950558, 0.00134934322, -0.00367342844, 0.00573950773, -0.0076224613, 0.00943887047, 1.00167406, 2.83297682] {
            p = c + p * w;
        }
        p * y
    };
    for _ in 0..2 {
        let err = erf(x) - y;
        x -= err / (2.0 / PI.sqrt() * (-x * x).exp());
    }
    x
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn normalize(a: [f64; 3]) -> [f64; 3] {
    let l = dot(a, a).sqrt();
    [a[0] / l, a[1] / l, a[2] / l]
}

#[cfg(test)]
mod tests;
