//! A path vertex of Mitsuba's `path` integrator as the probe path tracer (`crate::pathtrace`) sees it: eval,
//! sampling density and sampling of its BSDF (one record or a blend of two), with a masked surface's null
//! lobe (straight through with probability 1 - a, Mitsuba's `mask.cpp`) and radiance-mode scaling of
//! refractions. Shared by the probes and the bias compensation of clamped VPLs
//! (`crate::matrix::bias_compensation`), whose paths cross masks the same way.
use crate::lights::generate::sampling::{has_smooth_lobe_only, is_dielectric, pdf_bsdf, sample_bsdf, to_local, to_world, uniform};
use crate::raytrace::RayTracer;
use crate::scene::Scene;
use crate::shading::bsdf::{eval, resolve_records, FLAG_BLEND, KIND_ROUGHDIELECTRIC};
use crate::shading::GpuBsdf;
use crate::view::ViewSamples;
use glam::{Vec2, Vec3};
use rand_pcg::Pcg32;

/// A path vertex: point, normals, direction back along the path, BSDF (one record or a blend).
#[derive(Clone, Copy)]
pub(crate) struct Vertex {
    pub(crate) p: Vec3,
    pub(crate) n_s: Vec3,
    pub(crate) n_g: Vec3,
    pub(crate) wi: Vec3,
    pub(crate) first: GpuBsdf,
    /// A blend's second record and its weight w.
    pub(crate) second: Option<(GpuBsdf, f32)>,
    /// The opacity a of a masked surface (`mask`): eval and pdf are the nested BSDF's times a, and
    /// sampling passes straight through (a null event) with probability 1 - a.
    pub(crate) opacity: Option<f32>,
}

/// A BSDF sample in world space.
pub(crate) struct Sampled {
    pub(crate) w: Vec3,
    pub(crate) weight: Vec3,
    /// Solid-angle density (0 for a delta lobe).
    pub(crate) pdf: f32,
    pub(crate) delta: bool,
    /// Relative IOR crossed (1 unless refracted).
    pub(crate) eta: f32,
    /// A masked surface's null event (straight through; Mitsuba's `BSDFFlags::Null`, part of `Delta`).
    pub(crate) null: bool,
}

impl Vertex {
    pub(crate) fn eval(&self, w: Vec3) -> Vec3 {
        let (wi, wo) = (to_local(self.n_s, self.wi), to_local(self.n_s, w));
        let f = eval(&self.first, wi, wo);
        let f = match &self.second {
            Some((b, t)) => f * (1.0 - t) + eval(b, wi, wo) * *t,
            None => f,
        };
        f * self.opacity.unwrap_or(1.0)
    }

    pub(crate) fn pdf(&self, w: Vec3) -> f32 {
        let (wi, wo) = (to_local(self.n_s, self.wi), to_local(self.n_s, w));
        let p = pdf_bsdf(&self.first, wi, wo);
        let p = match &self.second {
            Some((b, t)) => p * (1.0 - t) + pdf_bsdf(b, wi, wo) * *t,
            None => p,
        };
        p * self.opacity.unwrap_or(1.0)
    }

    /// Whether some lobe is not delta (emitter sampling applies).
    pub(crate) fn has_smooth(&self) -> bool {
        // A roughdielectric carries no VPL (`has_smooth_lobe_only`) but its glossy lobes are sampled here.
        let glossy = |b: &GpuBsdf| !has_smooth_lobe_only(b) || b.kind == KIND_ROUGHDIELECTRIC;
        glossy(&self.first) || self.second.is_some_and(|(b, _)| glossy(&b))
    }

    pub(crate) fn sample(&self, rng: &mut Pcg32) -> Option<Sampled> {
        // Mitsuba's `mask.cpp` `sample`: the null lobe with probability 1 - a (weight 1, pdf 1 - a).
        let a = self.opacity.unwrap_or(1.0);
        if self.opacity.is_some() && uniform(rng) >= a {
            return Some(Sampled { w: -self.wi, weight: Vec3::ONE, pdf: 1.0 - a, delta: true, eta: 1.0, null: true });
        }
        let b = match &self.second {
            Some((b, t)) if uniform(rng) < *t => *b,
            _ => self.first,
        };
        let wi = to_local(self.n_s, self.wi);
        let s = sample_bsdf(&b, wi, rng)?;
        let w = to_world(self.n_s, s.wo);
        if s.delta {
            let mut weight = s.weight;
            let mut eta = 1.0;
            if is_dielectric(&b) && s.wo.z * wi.z < 0.0 {
                // Radiance mode: Mitsuba's dielectric scales a refraction by eta_ti^2.
                let eta_ti = if wi.z >= 0.0 { 1.0 / b.eta[0] } else { b.eta[0] };
                weight *= eta_ti * eta_ti;
                eta = 1.0 / eta_ti;
            }
            return Some(Sampled { w, weight, pdf: 0.0, delta: true, eta, null: false });
        }
        if self.second.is_none() {
            // The nested BSDF of a mask: its weight unchanged, its pdf times a.
            let pdf = a * pdf_bsdf(&b, wi, s.wo);
            let (mut weight, mut eta) = (s.weight, 1.0);
            if b.kind == KIND_ROUGHDIELECTRIC && s.wo.z * wi.z < 0.0 {
                // Radiance mode: Mitsuba's roughdielectric scales a transmission by 1 / eta^2.
                eta = if wi.z > 0.0 { b.eta[0] } else { b.eta[1] };
                weight /= eta * eta;
            }
            return (pdf > 0.0).then_some(Sampled { w, weight, pdf, delta: false, eta, null: false });
        }
        let pdf = self.pdf(w);
        if !(pdf > 0.0) {
            return None;
        }
        let weight = self.eval(w) / pdf;
        (weight.is_finite() && weight.max_element() > 0.0).then_some(Sampled { w, weight, pdf, delta: false, eta: 1.0, null: false })
    }
}

pub(crate) fn power_heuristic(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    if a2 + b2 > 0.0 && a2.is_finite() {
        a2 / (a2 + b2)
    } else if a.is_infinite() {
        1.0
    } else {
        0.0
    }
}

impl Vertex {
    /// The vertex at a ray hit on mesh `mesh` (triangle `prim`, texture coordinates `uv`): the scene's BSDF
    /// records there (a blend split into its two records), the bump or normal map applied, and the mask's
    /// opacity. `p` world position, `n_s` / `n_g` unit shading / geometric normals, `wi` the unit direction
    /// back along the path.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn at_hit(
        scene: &Scene,
        rt: &RayTracer,
        mesh: usize,
        prim: usize,
        p: Vec3,
        n_s: Vec3,
        n_g: Vec3,
        wi: Vec3,
        uv: Vec2,
    ) -> Vertex {
        let m = &scene.meshes[mesh];
        let (mut first, second) = resolve_records(&scene.bsdfs, &scene.textures, m.bsdf, uv);
        crate::shading::perturb::apply(scene, mesh, prim, p, n_g, n_s, uv, &mut [&mut first]);
        let second = second.map(|s| (s, first.extra[2]));
        if second.is_some() {
            first.flags &= !FLAG_BLEND;
            (first.extra[2], first.extra[3]) = (0.0, 0.0);
        }
        Vertex { p, n_s, n_g, wi, first, second, opacity: rt.masks().opacity(mesh, uv) }
    }

    /// View sample `i` of `view` as a vertex: its resolved records (a blend's second record is the view's
    /// record `extra[3]`). No opacity: a masked view sample's throughput already carries it
    /// (`view::chains`), and what lies behind is a view sample of its own.
    pub(crate) fn of_view_sample(view: &ViewSamples, i: usize) -> Vertex {
        let b = view.bsdf[i];
        let second = (b.flags & FLAG_BLEND != 0).then(|| view.bsdf.get(b.extra[3].to_bits() as usize).map(|s| (*s, b.extra[2]))).flatten();
        let mut first = b;
        if second.is_some() {
            first.flags &= !FLAG_BLEND;
            (first.extra[2], first.extra[3]) = (0.0, 0.0);
        }
        Vertex { p: view.position[i], n_s: view.normal[i], n_g: view.geo_normal[i], wi: view.wi[i], first, second, opacity: None }
    }
}
