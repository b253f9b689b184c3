//! The cluster tree of Lightcuts (Walter, Fernandez, Arbree, Bala, Donikian, Greenberg, "Lightcuts: a
//! scalable approach to illumination", SIGGRAPH 2005, Sec. 3-4) over a `LightSet`, and the upper bounds
//! of a cluster's contribution at a view sample.
//!
//! Topology: one tree per light type, as in the paper: omni (point and spot lights), oriented points
//! (area-light samples) and VPLs each get the light tree's topology (`lights::light_tree`, binned SAOH
//! over positions and orientation cones, built once over all lights) pruned to that type's boundable
//! lights (a node left with one child is replaced by it); directional lights (environment strata
//! included) get a tree split at the median of their directions along the longest axis of the direction
//! box. Deviation: the paper builds its trees by greedy agglomerative clustering, and keeps area-light
//! samples and VPLs in one oriented tree (separate here: their intensities differ by orders of magnitude,
//! and a mixed cluster's representative then stands badly for the other kind). The node bounds below
//! hold for any mix of kinds.
//!
//! Per node: a box (positions; for directional nodes the directions wo = -direction), an emission cone
//! (axis w, theta_o, theta_e as `LightBounds`), the summed intensity bound I_C (RGB), the representative
//! (a light of the node drawn at build time with probability proportional to lum(I_j) among its two
//! children's representatives: the paper's rule, so a split keeps one child's representative) and
//! scale = lum(I_C) / lum(I_rep). A cluster's estimate is A(i, rep) * scale: unbiased over the random
//! choice of representatives for every channel (deviation: the paper scales by the RGB intensity sum;
//! the scalar keeps colours of mixed clusters unbiased).
//!
//! Intensity bound I_j, with F_j(p) <= I_j ang_j(p) / d^2 (F the radiance factor of `LightSet::emitted`):
//! point and spot (no projected texture): I, ang <= 1 inside the cone of theta_o + theta_e; oriented
//! point: I0, ang = max(0, cos) to its normal (far field; near field below); point VPL on a diffuse BSDF
//! (n_s and n_g within 0.8 degrees): Phi R / pi, ang = |cos| to n_g on the particle's side; directional:
//! E, ang = 1, no distance.
//!
//! Bound of a node at view sample i (per channel; the refinement compares luminances):
//! `U = throughput * I_C * (D * min(cos_ub * G, clamp) + S * G)` with
//! - G = ang_ub / d_min^2, d_min the distance from p to the box (infinite inside it). ang_ub: with
//!   theta' = max(0, theta_w - theta_o - theta_b) (theta_w between w and p - box centre, theta_b the
//!   half-angle of the box's bounding sphere seen from p, 0 inside it), cos(theta') where every light of
//!   the node is cosine-weighted, else 1; 0 when theta' >= theta_e. A cosine-weighted node whose normals
//!   lie within theta_o <= 0.1 of w (a planar patch of area-light samples or of VPLs) also takes
//!   max(0, h) / d_min + theta_o, h the largest (p - x) . w over the box corners x: receivers behind
//!   the plane of every light get (nearly) 0. Directional nodes: G = 1.
//! - cos_ub >= |cos| between n and any direction to the box (the paper's bound: the box in the shading
//!   frame, max |z| / sqrt(min x^2 + min y^2 + max z^2)).
//! - the receiver's BSDF bounded as f_r |cos_o| <= D |cos_o| + S (`material_bound`): diffuse R / pi;
//!   plastic and roughplastic's diffuse lobe with transmittances and 1 - F bounded by 1; microfacet
//!   lobes (roughplastic's specular, roughconductor) S = spec * D_max / (4 cos_i) with G <= 1, F <= 1
//!   and D_max the distribution's maximum over all half-vectors (conservative: not direction-dependent,
//!   unlike the paper's Phong bound); blends by their weights; smooth and black BSDFs 0.
//! - clamp: the VPL clamp bounds G cos (F |cos_o| <= I_j clamp for a clamped point VPL) where every light
//!   of the node is one; infinite otherwise.
//! Fallbacks (lights and receivers without a bound): VSLs, VPLs on non-diffuse BSDFs and spots with a
//! projected texture are kept outside the trees and evaluated exactly at every view sample; an oriented
//! point's near field (receiver within `NEAR_FIELD_RADII` = 8 patch radii of its patch, `lights::patch`)
//! has no angular bound: there the patch rule gives `f_r(wo_j) I_j PSA(P+) / A(P+)`, and since
//! `PSA(P+) = int_{P+} |cos_r| cos_l / r^2 dA <= A(P+) / d_min^2` (the box holds every patch corner) a
//! node whose box is that close is bounded by `U = I_C D / d_min^2` on receivers without a constant part
//! (S = 0: f_r <= D); on glossy receivers (S > 0) and inside the box the bound is infinite (refined down
//! to single lights). A receiver with a `principled` BSDF has no bound: every light is evaluated exactly
//! there.
//!
//! Symbols: i view sample, j light, p / n receiver position and shading normal, I_C cluster intensity,
//! D / S the BSDF bound's cosine and constant parts, G geometric bound, U the node's bound.
use super::uniform;
use crate::cpu::ShadingPoint;
use crate::lights::light_tree::{LightBounds, LightTree};
use crate::lights::{patch, LightKind, LightSet};
use crate::shading::bsdf::{self, KIND_DIFFUSE, KIND_PLASTIC, KIND_PRINCIPLED, KIND_ROUGHCONDUCTOR, KIND_ROUGHPLASTIC};
use crate::shading::GpuBsdf;
use glam::{DVec3, Vec3};
use std::f64::consts::PI;

/// "No child" / "no parent".
pub const NONE: u32 = u32::MAX;
/// Relative padding of every bound (f32 shading against f64 bounds).
const PAD: f64 = 1.0 + 1e-3;

/// One node of the cluster tree (module docs).
#[derive(Debug, Clone, Copy)]
pub struct Node {
    pub lo: DVec3,
    pub hi: DVec3,
    pub w: DVec3,
    pub theta_o: f64,
    pub theta_e: f64,
    /// Every light below emits with a cosine about its axis.
    pub cosine: bool,
    /// Every light below is a clamped point VPL.
    pub clamped: bool,
    pub directional: bool,
    /// Largest near-field reach (m) of the patches below (0: none).
    pub near: f64,
    /// I_C, RGB.
    pub intensity: DVec3,
    /// lum(I_C).
    pub weight: f64,
    pub rep: u32,
    /// lum(I_rep).
    pub rep_weight: f64,
    /// lum(I_C) / lum(I_rep) (1 for leaves, 0 for an inner node of weight 0).
    pub scale: f64,
    pub children: [u32; 2],
}

impl Node {
    pub fn is_leaf(&self) -> bool {
        self.children[0] == NONE
    }
}

/// The cluster trees of a light set (module docs).
#[derive(Debug, Clone)]
pub struct CutTree {
    pub nodes: Vec<Node>,
    /// Roots: the omni, oriented-point, VPL and directional trees' (each when not empty).
    pub roots: Vec<u32>,
    /// Lights without a bound, evaluated exactly.
    pub exact: Vec<u32>,
    pub num_lights: usize,
}

fn lum(v: DVec3) -> f64 {
    (0.2126 * v.x + 0.7152 * v.y + 0.0722 * v.z).max(0.0)
}

fn v3(v: Vec3) -> DVec3 {
    v.as_dvec3()
}

/// Light j as a leaf (representative itself), None when it has no bound (an exact light).
fn leaf(lights: &LightSet, j: usize) -> Option<Node> {
    let p = v3(lights.position[j]);
    let i = v3(lights.intensity[j]).max(DVec3::ZERO);
    let mut n = Node {
        lo: p,
        hi: p,
        w: DVec3::Z,
        theta_o: PI,
        theta_e: PI / 2.0,
        cosine: false,
        clamped: false,
        directional: false,
        near: 0.0,
        intensity: i,
        weight: 0.0,
        rep: j as u32,
        rep_weight: 0.0,
        scale: 1.0,
        children: [NONE; 2],
    };
    match lights.kind[j] {
        LightKind::Point => {}
        LightKind::Spot => {
            if lights.spot_texture[j].is_some() {
                return None;
            }
            let (c, b) = (lights.cutoff_angle[j] as f64, lights.beam_width[j] as f64);
            (n.w, n.theta_o, n.theta_e) = (v3(lights.direction[j]).normalize(), b.min(c), c - b.min(c));
        }
        LightKind::Directional => {
            let wo = -v3(lights.direction[j]);
            (n.lo, n.hi, n.directional) = (wo, wo, true);
        }
        LightKind::OrientedPoint => {
            (n.w, n.theta_o, n.cosine) = (v3(lights.normal[j]).normalize(), 0.0, true);
            let c = &lights.patch[j];
            if !patch::is_none(c) {
                let nl = lights.normal[j];
                let surface = lights.position[j] - nl * (lights.position[j] - c[0]).dot(nl);
                let centre = (c[0] + c[1] + c[2] + c[3]) * 0.25;
                for q in c.iter().chain([&surface]) {
                    (n.lo, n.hi) = (n.lo.min(v3(*q)), n.hi.max(v3(*q)));
                }
                let r = c.iter().map(|q| (*q - centre).length()).fold(0.0f32, f32::max) as f64;
                n.near = patch::NEAR_FIELD_RADII as f64 * r * PAD + 1e-6;
            }
        }
        LightKind::Vpl => {
            let b: &GpuBsdf = &lights.bsdf[j];
            let (ns, ng) = (lights.normal[j], lights.geo_normal[j]);
            let side = lights.incident[j].dot(ng);
            let diffuse = b.kind == KIND_DIFFUSE && b.flags & bsdf::FLAG_BLEND == 0 && ns.dot(ng).abs() > 1.0 - 1e-4;
            if lights.vsl_radius[j] > 0.0 || !diffuse || side == 0.0 {
                return None;
            }
            let r = v3(Vec3::from_array(b.diffuse)).max(DVec3::ZERO);
            n.intensity = i * r / PI;
            (n.w, n.theta_o, n.cosine) = ((v3(ng) * side.signum() as f64).normalize(), 0.0, true);
            n.clamped = lights.vpl_clamp.is_finite();
        }
    }
    n.weight = lum(n.intensity);
    n.rep_weight = n.weight;
    Some(n)
}

impl CutTree {
    /// The trees over `lights` (module docs), representatives drawn with `seed`.
    ///
    /// Errors: `InvalidParameter` for an empty set.
    pub fn build(lights: &LightSet, seed: u64) -> crate::error::Result<CutTree> {
        let tree = LightTree::build(lights)?;
        let n = lights.len();
        let leaves: Vec<Option<Node>> = (0..n).map(|j| leaf(lights, j)).collect();
        let mut t = CutTree { nodes: Vec::with_capacity(2 * n), roots: Vec::new(), exact: Vec::new(), num_lights: n };
        t.exact = (0..n).filter(|&j| leaves[j].is_none()).map(|j| j as u32).collect();
        let mut rng = crate::lights::generate::sampling::stream(seed, 0x6c63_7574, 0);
        let mut choose = |a: &Node, b: &Node| uniform(&mut rng) * (a.weight + b.weight) >= a.weight;
        if !tree.nodes.is_empty() {
            for kind in [LightKind::Point, LightKind::OrientedPoint, LightKind::Vpl] {
                let group = |j: usize| {
                    let k = if lights.kind[j] == LightKind::Spot { LightKind::Point } else { lights.kind[j] };
                    k == kind
                };
                if let Some(r) = t.convert(&tree, 0, &leaves, &group, &mut choose) {
                    t.roots.push(r);
                }
            }
        }
        let mut dir: Vec<Node> = leaves.iter().flatten().filter(|l| l.directional).copied().collect();
        if !dir.is_empty() {
            let r = t.directional(&mut dir, &mut choose);
            t.roots.push(r);
        }
        Ok(t)
    }

    /// Node k of the light tree, pruned to the boundable lights j with `group(j)` (module docs).
    fn convert(
        &mut self,
        tree: &LightTree,
        k: usize,
        leaves: &[Option<Node>],
        group: &impl Fn(usize) -> bool,
        choose: &mut impl FnMut(&Node, &Node) -> bool,
    ) -> Option<u32> {
        if tree.is_leaf(k) {
            let j = tree.leaf_light[k] as usize;
            if !group(j) {
                return None;
            }
            let l = leaves[j]?;
            self.nodes.push(l);
            return Some(self.nodes.len() as u32 - 1);
        }
        let [c0, c1] = tree.children[k];
        let a = self.convert(tree, c0 as usize, leaves, group, choose);
        let b = self.convert(tree, c1 as usize, leaves, group, choose);
        match (a, b) {
            (Some(a), Some(b)) => Some(self.merge(a, b, choose)),
            (a, b) => a.or(b),
        }
    }

    /// A median-split tree over directional leaves.
    fn directional(&mut self, leaves: &mut [Node], choose: &mut impl FnMut(&Node, &Node) -> bool) -> u32 {
        if leaves.len() == 1 {
            self.nodes.push(leaves[0]);
            return self.nodes.len() as u32 - 1;
        }
        let (lo, hi) = leaves.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), l| (lo.min(l.lo), hi.max(l.lo)));
        let axis = (hi - lo).max_position();
        let mid = leaves.len() / 2;
        leaves.select_nth_unstable_by(mid, |a, b| a.lo[axis].total_cmp(&b.lo[axis]));
        let (l, r) = leaves.split_at_mut(mid);
        let a = self.directional(l, choose);
        let b = self.directional(r, choose);
        self.merge(a, b, choose)
    }

    /// A new inner node over nodes a and b.
    fn merge(&mut self, a: u32, b: u32, choose: &mut impl FnMut(&Node, &Node) -> bool) -> u32 {
        let (na, nb) = (self.nodes[a as usize], self.nodes[b as usize]);
        let cone = |x: &Node| LightBounds { lo: x.lo, hi: x.hi, w: x.w, theta_o: x.theta_o, theta_e: x.theta_e, phi: 0.0 };
        let u = cone(&na).union(&cone(&nb));
        let intensity = na.intensity + nb.intensity;
        let weight = lum(intensity);
        let (rep, w_rep) = if choose(&na, &nb) { (nb.rep, nb.rep_weight) } else { (na.rep, na.rep_weight) };
        self.nodes.push(Node {
            lo: u.lo,
            hi: u.hi,
            w: u.w,
            theta_o: u.theta_o,
            theta_e: u.theta_e,
            cosine: na.cosine && nb.cosine,
            clamped: na.clamped && nb.clamped,
            directional: na.directional,
            near: na.near.max(nb.near),
            intensity,
            weight,
            rep,
            rep_weight: w_rep,
            scale: if w_rep > 0.0 { weight / w_rep } else { 0.0 },
            children: [a, b],
        });
        self.nodes.len() as u32 - 1
    }

    /// The bound U of node k (module docs) at a view sample, per channel; `m` its `material_bound`.
    pub fn bound(&self, k: usize, sp: &ShadingPoint, m: &Material, clamp: f32) -> DVec3 {
        let node = &self.nodes[k];
        if node.weight == 0.0 || (m.d == DVec3::ZERO && m.s == DVec3::ZERO) {
            return DVec3::ZERO;
        }
        let frame = [v3(sp.s), v3(sp.t), v3(sp.n)];
        if node.directional {
            let cos_ub = cos_bound(node.lo, node.hi, &frame);
            return node.intensity * (m.d * cos_ub + m.s) * PAD;
        }
        let p = v3(sp.p);
        let d2 = (node.lo - p).max(DVec3::ZERO).max(p - node.hi).length_squared();
        if !(d2 > 0.0) {
            return DVec3::INFINITY;
        }
        if node.near > 0.0 && d2 < node.near * node.near {
            // Near field (module docs): f_r I_j PSA(P+) / A(P+) <= D I_j / d_min^2 per light, as in the
            // far field without the angular factors; a glossy receiver (S > 0) has no such bound.
            return if m.s == DVec3::ZERO { node.intensity * m.d / d2 * PAD * PAD } else { DVec3::INFINITY };
        }
        let ang = angular_bound(node, p, d2.sqrt());
        if ang == 0.0 {
            return DVec3::ZERO;
        }
        let g = ang / d2 * PAD;
        let cos_ub = cos_bound(node.lo - p, node.hi - p, &frame);
        let c = if node.clamped { clamp as f64 * PAD } else { f64::INFINITY };
        node.intensity * (m.d * (cos_ub * g).min(c) + m.s * g) * PAD
    }
}

/// ang_ub of a positional node seen from p at distance `d_min` from its box (module docs).
fn angular_bound(node: &Node, p: DVec3, d_min: f64) -> f64 {
    let cone = cone_bound(node, p);
    if !node.cosine || node.theta_o > 0.1 {
        return cone;
    }
    // A nearly planar cluster (normals within theta_o of w): n_k . v <= w . v + theta_o, and
    // w . v <= h / d_min with h the largest (p - x) . w over the box (<= 0: p behind every light).
    let mut h = f64::NEG_INFINITY;
    for c in 0..8 {
        let x = DVec3::new(
            if c & 1 == 0 { node.lo.x } else { node.hi.x },
            if c & 2 == 0 { node.lo.y } else { node.hi.y },
            if c & 4 == 0 { node.lo.z } else { node.hi.z },
        );
        h = h.max((p - x).dot(node.w));
    }
    let plane = (h.max(0.0) / d_min + node.theta_o) * PAD + 1e-6;
    cone.min(plane)
}

/// ang_ub from the cone alone (module docs).
fn cone_bound(node: &Node, p: DVec3) -> f64 {
    let c = (node.lo + node.hi) * 0.5;
    let r = (node.hi - node.lo).length() * 0.5;
    let dist = (p - c).length();
    if node.theta_o >= PI || dist <= r * PAD {
        return 1.0;
    }
    let theta_b = (r / dist).min(1.0).asin();
    let theta_w = node.w.dot((p - c) / dist).clamp(-1.0, 1.0).acos();
    let theta = (theta_w - node.theta_o - theta_b - 1e-6).max(0.0);
    if node.cosine {
        if theta >= PI / 2.0 {
            0.0
        } else {
            theta.cos()
        }
    } else if theta == 0.0 || theta < node.theta_e + 1e-6 {
        1.0
    } else {
        0.0
    }
}

/// An upper bound of |cos| between `frame[2]` and every vector of the box [lo, hi] (module docs).
pub fn cos_bound(lo: DVec3, hi: DVec3, frame: &[DVec3; 3]) -> f64 {
    let (mut a, mut b) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    for c in 0..8 {
        let v =
            DVec3::new(if c & 1 == 0 { lo.x } else { hi.x }, if c & 2 == 0 { lo.y } else { hi.y }, if c & 4 == 0 { lo.z } else { hi.z });
        let l = DVec3::new(v.dot(frame[0]), v.dot(frame[1]), v.dot(frame[2]));
        (a, b) = (a.min(l), b.max(l));
    }
    let min_sq = |lo: f64, hi: f64| if lo <= 0.0 && hi >= 0.0 { 0.0 } else { lo.abs().min(hi.abs()).powi(2) };
    let z = a.z.abs().max(b.z.abs());
    let xy = min_sq(a.x, b.x) + min_sq(a.y, b.y);
    if z == 0.0 {
        0.0
    } else {
        (z / (xy + z * z).sqrt() * PAD).min(1.0)
    }
}

/// The receiver's BSDF bound f_r |cos_o| <= d |cos_o| + s (module docs), throughput included;
/// `unbounded` for a `principled` record.
#[derive(Debug, Clone, Copy, Default)]
pub struct Material {
    pub d: DVec3,
    pub s: DVec3,
    pub unbounded: bool,
}

/// The largest value of the microfacet distribution over all half-vectors.
fn d_max(b: &GpuBsdf) -> f64 {
    let (au, av) = (b.alpha_u as f64, b.alpha_v as f64);
    let amax = au.max(av);
    if b.flags & bsdf::FLAG_GGX != 0 {
        // D = 1 / (pi au av s^2), s = x^2/au^2 + y^2/av^2 + z^2 >= min(1, 1/amax^2).
        let s = (1.0f64).min(1.0 / (amax * amax));
        1.0 / (PI * au * av * s * s)
    } else {
        // exp(-tan^2 / amax^2) / cos^4 peaks at tan^2 = 2 amax^2 - 1 when that is > 0.
        let u = (2.0 * amax * amax - 1.0).max(0.0);
        (-u / (amax * amax)).exp() * (1.0 + u) * (1.0 + u) / (PI * au * av)
    }
}

fn record_bound(b: &GpuBsdf, wi: Vec3) -> (DVec3, DVec3, bool) {
    let cos_i = if b.flags & bsdf::FLAG_TWOSIDED != 0 { wi.z.abs() } else { wi.z } as f64;
    if b.kind == KIND_PRINCIPLED || b.kind == bsdf::KIND_ROUGHDIELECTRIC {
        return (DVec3::ZERO, DVec3::ZERO, true);
    }
    if !(cos_i > 0.0) {
        return (DVec3::ZERO, DVec3::ZERO, false);
    }
    let diffuse = v3(Vec3::from_array(b.diffuse)).max(DVec3::ZERO);
    let specular = v3(Vec3::from_array(b.specular)).max(DVec3::ZERO);
    let nonlinear = b.flags & bsdf::FLAG_NONLINEAR != 0;
    let plastic_diffuse = |internal: f64| {
        let den = DVec3::ONE - if nonlinear { diffuse * internal } else { DVec3::splat(internal) };
        diffuse / den.max(DVec3::splat(1e-6)) * (b.eta[1] as f64 / PI)
    };
    match b.kind {
        KIND_DIFFUSE => (diffuse / PI, DVec3::ZERO, false),
        KIND_PLASTIC => (plastic_diffuse(b.extra[0] as f64), DVec3::ZERO, false),
        KIND_ROUGHPLASTIC => (plastic_diffuse(b.extra[0] as f64), specular * (d_max(b) / (4.0 * cos_i)), false),
        KIND_ROUGHCONDUCTOR => (DVec3::ZERO, specular * (d_max(b) / (4.0 * cos_i)), false),
        _ => (DVec3::ZERO, DVec3::ZERO, false),
    }
}

/// The bound of view sample i's BSDF records (blends by weight), times its throughput.
pub fn material_bound(records: &[GpuBsdf], i: usize, sp: &ShadingPoint) -> Material {
    let b = &records[i];
    let (mut d, mut s, mut unbounded) = record_bound(b, sp.wi_local);
    if b.flags & bsdf::FLAG_BLEND != 0 {
        let w = b.extra[2] as f64;
        let (d1, s1, u1) =
            records.get(b.extra[3].to_bits() as usize).map_or((DVec3::ZERO, DVec3::ZERO, false), |r| record_bound(r, sp.wi_local));
        d = d * (1.0 - w) + d1 * w;
        s = s * (1.0 - w) + s1 * w;
        unbounded |= u1;
    }
    let t = v3(sp.throughput).max(DVec3::ZERO);
    Material { d: d * t, s: s * t, unbounded }
}
