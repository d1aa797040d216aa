//! The exported glTF material in a real engine: three.js (npm `three@0.187.0`, r187) in
//! headless Chromium against `fit-brdf render` of the same model, light and camera.
//!
//! tests/engines/threejs.cjs serves three.js from `target/browser-test/node_modules` on
//! 127.0.0.1 (never a CDN), loads each `export --to gltf` file with `GLTFLoader` onto a
//! unit sphere, lights it with one `DirectionalLight` (no environment, `NoToneMapping`,
//! linear output), renders into a `FloatType` `WebGLRenderTarget` and reads the float
//! pixels back. This test renders the same model with `fit-brdf render` (a perspective
//! camera of the same field of view, one directional light of the same irradiance, one
//! ray through each pixel centre, as WebGL rasterises) and states the relative RMS
//! difference per variant: core, sheen, clearcoat, specular (and a metal core).
//!
//! **Light convention.** Since r155 three.js lights are physical by default (the legacy
//! mode went in r165): a `DirectionalLight`'s `color · intensity` is the irradiance E on
//! a surface facing it, the reflected radiance is f_r · E · cos θi, and `BRDF_Lambert` is
//! diffuseColor / π. That is `fit-brdf render`'s directional light exactly (docs/
//! rendering.md), so `intensity` = `irradiance` with no factor π.
//!
//! **Where three.js differs from the specification**, term by term, is [`Term`]: this
//! test evaluates r187's direct-light shading (`lights_physical_pars_fragment`,
//! `lights_fragment_begin`, `meshphysical.glsl`) at every pixel's exact geometry with each
//! term either as three.js has it or as the specification (and brdfkit) has it. With
//! every term as the specification's it reproduces brdfkit's render (a check of the
//! reimplementation); with every term as three.js's it must reproduce three.js's pixels
//! (within 1 %, and within a tenth of any difference above 2 %: the difference *is*
//! accounted for); switching one term at a time shows what each contributes.
//! docs/export.md has the table this test prints (`-- --nocapture`); with
//! `BRDFKIT_ENGINE_SHOTS=DIR` it keeps three.js's canvases as PNGs there.
//!
//! Needs chromium, node and `npm install --prefix target/browser-test playwright-core@1.65.1
//! three@0.187.0` (`.ci/run` does it); ignored with the reason otherwise, failing under CI.

#[macro_use]
mod common;
#[path = "../../../build/external_tools.rs"]
#[macro_use]
mod external_tools;

use brdfkit::models::sheen::{SheenVisibility, sheen_albedo};
use common::{export_gltf, gltf_extension_variants, stderr};
use serde_json::{Value, json};
use std::f64::consts::PI;
use std::path::{Path, PathBuf};

/// Image side, pixels.
const SIZE: usize = 256;
/// Camera distance from the sphere's centre and the field of view (degrees): the unit
/// sphere spans ~226 pixels.
const CAMERA_Z: f64 = 10.0;
const FOV: f64 = 13.0;
/// Irradiance of the directional light (W/m², three.js `intensity`).
const IRRADIANCE: f64 = 3.0;
/// Pixels whose sphere normal is this close to the silhouette (n · v) are left out: a
/// tessellated sphere's edge pixels cover the background partly.
const MIN_COS_VIEW: f64 = 0.1;

type V3 = [f64; 3];

fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn normalize(a: V3) -> V3 {
    let l = dot(a, a).sqrt();
    [a[0] / l, a[1] / l, a[2] / l]
}

/// The direction towards the light (unit): up-left-front, so the image holds normal,
/// grazing and back-lit views.
fn light_from() -> V3 {
    normalize([-0.4, 0.5, 0.77])
}

/// One `gltf-pbr-ext` description per variant (the `gltf-pbr` core where it has none):
/// the cores and each extension alone.
fn variants() -> Vec<(&'static str, Value)> {
    let core = json!({"base_color": [0.6, 0.2, 0.1], "metallic": 0.0, "roughness": 0.5});
    let metal = json!({"base_color": [0.9, 0.6, 0.3], "metallic": 1.0, "roughness": 0.5});
    let mut v = vec![
        ("core", json!({"model": "gltf-pbr", "params": core})),
        ("core-metal", json!({"model": "gltf-pbr", "params": metal})),
    ];
    v.extend(
        gltf_extension_variants(&core)
            .into_iter()
            .filter(|(n, _)| *n != "all"),
    );
    v
}

/// `fit-brdf render` of `model` under the shared light and camera: linear RGB, rows
/// top-down.
fn brdfkit_render(dir: &Path, name: &str, model: &Value) -> Vec<[f32; 3]> {
    let l = light_from();
    let scene = format!(
        "effects = [\"direct\"]\n[film]\nwidth = {SIZE}\nheight = {SIZE}\nspp = 1\nfilter = \"center\"\n\
         [camera]\nposition = [0.0, 0.0, {CAMERA_Z:?}]\nlook_at = [0.0, 0.0, 0.0]\nup = [0.0, 1.0, 0.0]\nfov = {FOV:?}\n\
         [sphere]\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\n[material]\nmodel = \"{name}.json\"\n\
         [[light]]\ntype = \"directional\"\ndirection = [{:?}, {:?}, {:?}]\nirradiance = {IRRADIANCE:?}\n",
        -l[0], -l[1], -l[2]
    );
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(&path, scene).unwrap();
    std::fs::write(dir.join(format!("{name}.json")), model.to_string()).unwrap();
    let exr = dir.join(format!("{name}.exr"));
    let o = fit_brdf!("render", &path, "--out", &exr, "--quiet");
    assert!(o.status.success(), "render {name}: {}", stderr(&o));
    let img = image::open(&exr).unwrap().to_rgb32f();
    assert_eq!(img.dimensions(), (SIZE as u32, SIZE as u32));
    img.pixels().map(|p| p.0).collect()
}

/// What tests/engines/threejs.cjs rendered: per material, RGBA rows top-down.
struct ThreeRender {
    info: Value,
    rgba: Vec<f64>,
}

/// Runs tests/engines/threejs.cjs on `materials` (name, file); `shots` keeps PNGs.
fn threejs_render(
    dir: &Path,
    materials: &[(&str, PathBuf)],
    shots: Option<&Path>,
) -> Vec<ThreeRender> {
    let (driver, exe) = external_tools::require_threejs();
    let l = light_from();
    let scene = json!({
        "size": SIZE, "camera": {"position": [0.0, 0.0, CAMERA_Z], "fov": FOV},
        "light": {"from": l, "irradiance": IRRADIANCE}, "segments": [512, 256],
        "materials": materials.iter().map(|(n, f)| json!({"name": n, "file": f})).collect::<Vec<_>>(),
    });
    let scene_path = dir.join("three-scene.json");
    std::fs::write(&scene_path, scene.to_string()).unwrap();
    let out = dir.join("three.json");
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/engines/threejs.cjs");
    let mut cmd = std::process::Command::new("node");
    cmd.arg(&script).arg(&scene_path).arg(&out).arg(&exe);
    if let Some(s) = shots {
        cmd.arg(s);
    }
    let o = cmd
        .env("NODE_PATH", driver.join("node_modules"))
        .output()
        .unwrap();
    assert!(o.status.success(), "three.js: {}\n{}", o.status, stderr(&o));
    let v: Value = serde_json::from_slice(&std::fs::read(&out).unwrap()).unwrap();
    assert_eq!(v["errors"], json!([]), "{}", v["errors"]);
    v["renders"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| ThreeRender {
            info: r["info"].clone(),
            rgba: r["rgba"]
                .as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_f64().unwrap())
                .collect(),
        })
        .collect()
}

/// A pixel's geometry: the sphere normal, the direction to the camera, and the
/// normal's change to the next pixel right and down (three.js's `dFdx`, `dFdy`).
#[derive(Clone, Copy)]
struct Pixel {
    n: V3,
    v: V3,
}

/// The camera ray through pixel centre (x + ½, y + ½), as `fit-brdf render` and WebGL
/// take it, and where it meets the unit sphere.
fn pixel(x: f64, y: f64) -> Option<Pixel> {
    let t = (FOV.to_radians() / 2.0).tan();
    let s = SIZE as f64;
    let d = normalize([(2.0 * x / s - 1.0) * t, (1.0 - 2.0 * y / s) * t, -1.0]);
    let o = [0.0, 0.0, CAMERA_Z];
    let b = dot(o, d);
    let disc = b * b - (dot(o, o) - 1.0);
    if disc < 0.0 {
        return None;
    }
    let h = -b - disc.sqrt();
    let n = [o[0] + h * d[0], o[1] + h * d[1], o[2] + h * d[2]];
    Some(Pixel {
        n,
        v: [-d[0], -d[1], -d[2]],
    })
}

/// three.js's geometryRoughness: the largest component of the normal's change across
/// the pixel's 2×2 quad, horizontally and vertically.
fn geometry_roughness(x: usize, y: usize) -> f64 {
    let c = |x: usize, y: usize| pixel(x as f64 + 0.5, y as f64 + 0.5).map(|p| p.n);
    let (x0, y0) = (x & !1, y & !1);
    let (Some(l), Some(r), Some(t), Some(b)) = (c(x0, y), c(x0 + 1, y), c(x, y0), c(x, y0 + 1))
    else {
        return 0.0;
    };
    (0..3)
        .map(|i| (r[i] - l[i]).abs().max((b[i] - t[i]).abs()))
        .fold(0.0, f64::max)
}

/// Where three.js r187's direct light differs from the specification (and brdfkit).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Term {
    /// Roughness (core and coat) floored at 0.045 ("punctual lights need a minimum
    /// roughness"); the specification has none.
    MinRoughness,
    /// Roughness (core and coat) raised by the screen-space change of the normal
    /// (`geometryRoughness`, specular anti-aliasing).
    GeometryRoughness,
    /// Direct specular × (1 + F0 (1/E_ss − 1)), Turquin 2019's multiple-scattering
    /// compensation, E_ss from three.js's 16×16 half-float DFG table.
    MultiScatter,
    /// Sheen visibility: Neubelt & Pettineo's 1/(4 (NL + NV − NL·NV)) for the
    /// specification's Charlie (Estevez & Kulla) form.
    SheenVisibility,
    /// Sheen albedo E: three.js's fitted exp(a μ + b) (`IBLSheenBRDF`) for a table.
    SheenAlbedo,
    /// The coat lobe's Fresnel at V·H (three.js `BRDF_GGX_Clearcoat`) where
    /// `KHR_materials_clearcoat` weights the coat by its Fresnel at N·V only.
    CoatFresnel,
    /// The base's diffuse weighted per channel by 1 − F (three.js) where
    /// `KHR_materials_specular`'s `fresnel_mix` takes 1 − max(F) over the channels (the
    /// same for a grey F0).
    DiffusePerChannel,
}

const TERMS: [Term; 7] = [
    Term::MinRoughness,
    Term::GeometryRoughness,
    Term::MultiScatter,
    Term::SheenVisibility,
    Term::SheenAlbedo,
    Term::CoatFresnel,
    Term::DiffusePerChannel,
];

/// The material's factors as three.js's `GLTFLoader` sets them.
#[derive(Clone, Copy, Default)]
struct Factors {
    base: V3,
    metallic: f64,
    roughness: f64,
    sheen: Option<(V3, f64)>,
    coat: Option<(f64, f64)>,
    /// specularFactor, specularColorFactor, ior.
    specular: (f64, V3, f64),
}

fn rgb(v: &Value) -> V3 {
    [
        v[0].as_f64().unwrap(),
        v[1].as_f64().unwrap(),
        v[2].as_f64().unwrap(),
    ]
}

/// The factors of the exported file (its material 0).
fn factors(gltf: &Value) -> Factors {
    let m = &gltf["materials"][0];
    let pbr = &m["pbrMetallicRoughness"];
    let e = &m["extensions"];
    let sp = &e["KHR_materials_specular"];
    Factors {
        base: rgb(&pbr["baseColorFactor"]),
        metallic: pbr["metallicFactor"].as_f64().unwrap(),
        roughness: pbr["roughnessFactor"].as_f64().unwrap(),
        sheen: e.get("KHR_materials_sheen").map(|s| {
            (
                rgb(&s["sheenColorFactor"]),
                s["sheenRoughnessFactor"].as_f64().unwrap(),
            )
        }),
        coat: e.get("KHR_materials_clearcoat").map(|c| {
            (
                c["clearcoatFactor"].as_f64().unwrap(),
                c["clearcoatRoughnessFactor"].as_f64().unwrap(),
            )
        }),
        specular: (
            sp.get("specularFactor")
                .map_or(1.0, |v| v.as_f64().unwrap()),
            sp.get("specularColorFactor").map_or([1.0; 3], rgb),
            e["KHR_materials_ior"]
                .get("ior")
                .map_or(1.5, |v| v.as_f64().unwrap()),
        ),
    }
}

/// three.js's DFG table (src/renderers/shaders/DFGLUTData.js): 16 × 16 texels of
/// (scale, bias) half floats, u = roughness, v = N·V, sampled bilinearly with
/// clamp-to-edge as `texture2D` does.
struct Dfg(Vec<[f64; 2]>);

impl Dfg {
    fn load(driver: &Path) -> Dfg {
        let p = driver.join("node_modules/three/src/renderers/shaders/DFGLUTData.js");
        let text = std::fs::read_to_string(&p).unwrap();
        let body = &text[text.find("Uint16Array").unwrap()..text.find("] );").unwrap()];
        let halves: Vec<f64> = body
            .split("0x")
            .skip(1)
            .map(|h| half(u16::from_str_radix(&h[..4], 16).unwrap()))
            .collect();
        assert_eq!(halves.len(), 512, "{}", p.display());
        Dfg(halves.chunks(2).map(|c| [c[0], c[1]]).collect())
    }

    /// E_ss = scale + bias at (roughness, N·V).
    fn ess(&self, roughness: f64, nv: f64) -> f64 {
        let coord = |u: f64| {
            let t = (u * 16.0 - 0.5).clamp(0.0, 15.0);
            let i = (t.floor() as usize).min(14);
            (i, t - i as f64)
        };
        let ((i, fu), (j, fv)) = (coord(roughness), coord(nv));
        let at = |i: usize, j: usize| self.0[j * 16 + i][0] + self.0[j * 16 + i][1];
        let top = at(i, j) * (1.0 - fu) + at(i + 1, j) * fu;
        let bottom = at(i, j + 1) * (1.0 - fu) + at(i + 1, j + 1) * fu;
        top * (1.0 - fv) + bottom * fv
    }
}

/// IEEE 754 binary16 to f64.
fn half(h: u16) -> f64 {
    let (s, e, m) = ((h >> 15) as i32, ((h >> 10) & 31) as i32, (h & 1023) as f64);
    let v = if e == 0 {
        m * 2f64.powi(-24)
    } else {
        (1.0 + m / 1024.0) * 2f64.powi(e - 15)
    };
    if s == 1 { -v } else { v }
}

/// Schlick's Fresnel F0 + (F90 − F0)(1 − c)⁵.
fn schlick(f0: f64, f90: f64, c: f64) -> f64 {
    f0 + (f90 - f0) * (1.0 - c.clamp(0.0, 1.0)).powi(5)
}

/// GGX D times the height-correlated Smith V (three.js `D_GGX`,
/// `V_GGX_SmithCorrelated`; the specification's and brdfkit's `smith-correlated`).
fn ggx_dv(alpha: f64, nl: f64, nv: f64, nh: f64) -> f64 {
    let a2 = alpha * alpha;
    let gv = nl * (a2 + (1.0 - a2) * nv * nv).sqrt();
    let gl = nv * (a2 + (1.0 - a2) * nl * nl).sqrt();
    let denom = nh * nh * (a2 - 1.0) + 1.0;
    0.5 / (gv + gl).max(1e-6) * a2 / (PI * denom * denom)
}

/// The Charlie sheen distribution; three.js floors sin²θh at 2⁻⁷ (fp16 safety), which
/// goes with its visibility term here.
fn charlie_d(sheen_roughness: f64, nh: f64, three: bool) -> f64 {
    let alpha = sheen_roughness * sheen_roughness;
    let s2 = (1.0 - nh * nh).max(if three { 0.0078125 } else { 0.0 });
    (2.0 + 1.0 / alpha) * s2.powf(0.5 / alpha) / (2.0 * PI)
}

/// Charlie's sheen visibility (KHR_materials_sheen "Implementation Notes", Estevez &
/// Kulla 2017), clamped at 1 as the reference renderers (and brdfkit) do.
fn charlie_v(sheen_roughness: f64, nl: f64, nv: f64) -> f64 {
    let alpha = sheen_roughness * sheen_roughness;
    let t = (1.0 - alpha) * (1.0 - alpha);
    let p = |a: f64, b: f64| a + (b - a) * t;
    let (a, b, c, d, e) = (
        p(21.5473, 25.3245),
        p(3.82987, 3.32435),
        p(0.19823, 0.16801),
        p(-1.97760, -1.27393),
        p(-4.32054, -4.85967),
    );
    let l = |x: f64| a / (1.0 + b * x.powf(c)) + d * x + e;
    let lambda = |mu: f64| {
        if mu < 0.5 {
            l(mu).exp()
        } else {
            (2.0 * l(0.5) - l(1.0 - mu)).exp()
        }
    };
    (1.0 / ((1.0 + lambda(nv) + lambda(nl)) * 4.0 * nl * nv)).min(1.0)
}

/// three.js's `IBLSheenBRDF`: its curve fit of the Charlie sheen's albedo.
fn three_sheen_albedo(sheen_roughness: f64, mu: f64) -> f64 {
    let r = sheen_roughness;
    let r_inv = 1.0 / (r + 0.1);
    let a = -1.9362 + 1.0678 * r + 0.4573 * r * r - 0.8469 * r_inv;
    let b = -0.6014 + 0.5538 * r - 0.4670 * r * r - 0.1255 * r_inv;
    (a * mu + b).exp().clamp(0.0, 1.0)
}

/// Per-pixel inputs of [`shade`].
struct Shading<'a> {
    f: &'a Factors,
    dfg: &'a Dfg,
    /// three.js's terms (the rest as the specification has them).
    three: &'a [Term],
    geometry_roughness: f64,
}

impl Shading<'_> {
    fn has(&self, t: Term) -> bool {
        self.three.contains(&t)
    }

    /// A roughness factor as the shader takes it.
    fn roughness(&self, r: f64) -> f64 {
        let mut r = r;
        if self.has(Term::MinRoughness) {
            r = r.max(0.045);
        }
        if self.has(Term::GeometryRoughness) {
            r += self.geometry_roughness;
        }
        r.min(1.0)
    }
}

/// Radiance towards `p.v` under the light, per channel: three.js r187's
/// `RE_Direct_Physical` and `meshphysical` composition with the terms of `s.three` as
/// three.js has them and the others as the specification (and brdfkit's `gltf-pbr-ext`)
/// has them.
fn shade(s: &Shading, p: Pixel, l: V3) -> V3 {
    let f = s.f;
    let (n, v) = (p.n, p.v);
    let h = normalize([l[0] + v[0], l[1] + v[1], l[2] + v[2]]);
    let (nl, nv) = (dot(n, l).max(0.0), dot(n, v).max(0.0));
    let (nh, vh) = (dot(n, h).clamp(0.0, 1.0), dot(v, h).clamp(0.0, 1.0));
    if nl <= 0.0 || nv <= 0.0 {
        return [0.0; 3];
    }
    let rough = s.roughness(f.roughness);
    let (spec_w, spec_c, ior) = f.specular;
    let f0_ior = ((ior - 1.0) / (ior + 1.0)).powi(2);
    let f90 = spec_w + (1.0 - spec_w) * f.metallic;
    let dv = ggx_dv(rough * rough, nl, nv, nh);
    let ess = s.dfg.ess(rough, nv);
    let mut irr = IRRADIANCE * nl;
    let mut sheen = [0.0; 3];
    if let Some((sc, sr)) = f.sheen {
        let sr = sr.clamp(1e-4, 1.0);
        let three = s.has(Term::SheenVisibility);
        let vis = if three {
            (1.0 / (4.0 * (nl + nv - nl * nv))).min(1.0)
        } else {
            charlie_v(sr, nl, nv)
        };
        let lobe = charlie_d(sr, nh, three) * vis;
        let e = |mu: f64| {
            if s.has(Term::SheenAlbedo) {
                three_sheen_albedo(sr, mu)
            } else {
                sheen_albedo(SheenVisibility::Charlie, sr, mu).0
            }
        };
        let max_c = sc[0].max(sc[1]).max(sc[2]);
        sheen = [0, 1, 2].map(|i| irr * sc[i] * lobe);
        irr *= 1.0 - max_c * e(nv).max(e(nl));
    }
    let f0 = [0, 1, 2].map(|i| (f0_ior * spec_c[i]).min(1.0) * spec_w);
    let fd = f0.map(|f0| schlick(f0, f90, vh));
    let fd_max = fd[0].max(fd[1]).max(fd[2]);
    let mut out = [0.0; 3];
    for i in 0..3 {
        let f0_blend = f0[i] + (f.base[i] - f0[i]) * f.metallic;
        let ms = if s.has(Term::MultiScatter) {
            1.0 + f0_blend * (1.0 / ess - 1.0)
        } else {
            1.0
        };
        let specular = schlick(f0_blend, f90, vh) * dv * ms;
        let fd = if s.has(Term::DiffusePerChannel) {
            fd[i]
        } else {
            fd_max
        };
        let diffuse = f.base[i] * (1.0 - f.metallic) / PI * (1.0 - fd);
        out[i] = irr * (specular + diffuse) + sheen[i];
    }
    if let Some((cc, cr)) = f.coat {
        let cr = s.roughness(cr);
        let fcc = schlick(0.04, 1.0, nv);
        let lobe_f = if s.has(Term::CoatFresnel) {
            schlick(0.04, 1.0, vh)
        } else {
            fcc
        };
        let coat = IRRADIANCE * nl * lobe_f * ggx_dv(cr * cr, nl, nv, nh);
        out = out.map(|o| o * (1.0 - cc * fcc) + cc * coat);
    }
    out
}

/// The pixels compared: on the sphere, away from its silhouette (n · v ≥
/// [`MIN_COS_VIEW`]), and covered in three.js's render (alpha 1).
fn mask(three: &ThreeRender) -> Vec<(usize, usize, Pixel)> {
    let mut m = Vec::new();
    for y in 0..SIZE {
        for x in 0..SIZE {
            let Some(p) = pixel(x as f64 + 0.5, y as f64 + 0.5) else {
                continue;
            };
            if dot(p.n, p.v) >= MIN_COS_VIEW && three.rgba[(y * SIZE + x) * 4 + 3] == 1.0 {
                m.push((x, y, p));
            }
        }
    }
    m
}

/// Relative RMS of `a` against `b` over the same pixels and channels:
/// √(Σ (a − b)² / Σ b²).
fn rel_rms(a: &[V3], b: &[V3]) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        for i in 0..3 {
            num += (x[i] - y[i]).powi(2);
            den += y[i] * y[i];
        }
    }
    (num / den).sqrt()
}

/// The reimplementation's image over the masked pixels with `three`'s terms.
fn reimplemented(f: &Factors, dfg: &Dfg, px: &[(usize, usize, Pixel)], three: &[Term]) -> Vec<V3> {
    px.iter()
        .map(|&(x, y, p)| {
            let s = Shading {
                f,
                dfg,
                three,
                geometry_roughness: geometry_roughness(x, y),
            };
            shade(&s, p, light_from())
        })
        .collect()
}

/// One variant's figures.
struct Row {
    name: &'static str,
    /// Pixels compared.
    pixels: usize,
    /// three.js against brdfkit.
    measured: f64,
    /// The reimplementation with every term as three.js's, against three.js.
    unexplained: f64,
    /// The specification's terms against brdfkit's render (the reimplementation's check).
    spec_check: f64,
    /// Per term: brdfkit's image with that term switched to three.js's, against brdfkit.
    per_term: Vec<(Term, f64)>,
}

fn compare(
    name: &'static str,
    gltf: &Value,
    ours: &[[f32; 3]],
    three: &ThreeRender,
    dfg: &Dfg,
) -> Row {
    let f = factors(gltf);
    let px = mask(three);
    assert!(px.len() > 5000, "{name}: {} pixels on the sphere", px.len());
    let brdfkit: Vec<V3> = px
        .iter()
        .map(|&(x, y, _)| ours[y * SIZE + x].map(f64::from))
        .collect();
    let threejs: Vec<V3> = px
        .iter()
        .map(|&(x, y, _)| {
            let k = (y * SIZE + x) * 4;
            [three.rgba[k], three.rgba[k + 1], three.rgba[k + 2]]
        })
        .collect();
    let spec = reimplemented(&f, dfg, &px, &[]);
    let all = reimplemented(&f, dfg, &px, &TERMS);
    let per_term = TERMS
        .iter()
        .map(|&t| (t, rel_rms(&reimplemented(&f, dfg, &px, &[t]), &brdfkit)))
        .collect();
    Row {
        name,
        pixels: px.len(),
        measured: rel_rms(&threejs, &brdfkit),
        unexplained: rel_rms(&threejs, &all),
        spec_check: rel_rms(&spec, &brdfkit),
        per_term,
    }
}

/// `GLTFLoader` made a `MeshPhysicalMaterial` with the file's extension factors (float32).
fn loader_read_the_extensions(name: &str, f: &Factors, info: &Value) {
    let near = |key: &str, want: f64| {
        let got = info[key].as_f64().unwrap_or(f64::NAN);
        assert!(
            (got - want).abs() < 1e-6,
            "{name}: three.js {key} = {got}, the file has {want}: {info}"
        );
    };
    near("roughness", f.roughness);
    near("metalness", f.metallic);
    if let Some((_, sr)) = f.sheen {
        near("sheen", 1.0);
        near("sheenRoughness", sr);
    }
    if let Some((c, cr)) = f.coat {
        near("clearcoat", c);
        near("clearcoatRoughness", cr);
    }
    if f.sheen.is_some() || f.coat.is_some() || f.specular != (1.0, [1.0; 3], 1.5) {
        assert_eq!(
            info["material"].as_str().unwrap().split(' ').next(),
            Some("MeshPhysicalMaterial"),
            "{name}"
        );
        near("ior", f.specular.2);
        near("specularIntensity", f.specular.0);
    }
}

fn print_rows(rows: &[Row]) {
    eprintln!(
        "| variant | pixels | three.js vs brdfkit | three.js vs reimplementation (all three.js terms) | spec reimplementation vs brdfkit | per term (brdfkit with that term as three.js's) |"
    );
    eprintln!("|---|---|---|---|---|---|");
    for r in rows {
        let terms: Vec<String> = r
            .per_term
            .iter()
            .filter(|(_, v)| *v > 1e-5)
            .map(|(t, v)| format!("{t:?} {:.2} %", 100.0 * v))
            .collect();
        eprintln!(
            "| {} | {} | {:.2} % | {:.2} % | {:.4} % | {} |",
            r.name,
            r.pixels,
            100.0 * r.measured,
            100.0 * r.unexplained,
            100.0 * r.spec_check,
            terms.join(", ")
        );
    }
}

threejs_test! {
    fn threejs_renders_the_exported_extensions_as_brdfkit_does() {
        let (driver, _) = external_tools::require_threejs();
        let dfg = Dfg::load(&driver);
        let d = tempfile::tempdir().unwrap();
        let vs = variants();
        let files: Vec<(&str, PathBuf)> = vs.iter().map(|(n, m)| (*n, export_gltf(d.path(), n, m))).collect();
        let shots = std::env::var_os("BRDFKIT_ENGINE_SHOTS").map(PathBuf::from);
        let renders = threejs_render(d.path(), &files, shots.as_deref());
        let mut rows = Vec::new();
        for (((name, model), (_, file)), three) in vs.iter().zip(&files).zip(&renders) {
            assert_eq!(three.info["revision"], "187", "{}", three.info);
            assert_eq!(three.info["float"], true, "EXT_color_buffer_float: {}", three.info);
            let gltf: Value = serde_json::from_str(&std::fs::read_to_string(file).unwrap()).unwrap();
            loader_read_the_extensions(name, &factors(&gltf), &three.info);
            let ours = brdfkit_render(d.path(), name, model);
            rows.push(compare(name, &gltf, &ours, three, &dfg));
        }
        print_rows(&rows);
        for r in &rows {
            // The reimplementation is the specification: it reproduces brdfkit's render.
            assert!(r.spec_check < 1e-4, "{}: spec reimplementation off by {}", r.name, r.spec_check);
            // three.js's pixels are its documented terms and nothing else: what remains is
            // the GPU's screen-space derivative in geometryRoughness (it scales with that
            // term: halving the pixel size halves both).
            assert!(r.unexplained < 0.01, "{}: {:.3} % not accounted for", r.name, 100.0 * r.unexplained);
            assert!(
                r.measured < 0.02 || r.unexplained < 0.1 * r.measured,
                "{}: the terms account for too little of {:.2} % ({:.2} % left)",
                r.name,
                100.0 * r.measured,
                100.0 * r.unexplained
            );
        }
        assert!(rows[0].measured < 0.02, "core: {:.2} %", 100.0 * rows[0].measured);
    }
}

#[test]
fn the_reimplementation_is_not_blind() {
    // The comparison can fail: a core whose three.js terms are all switched differs from
    // the specification's image, and each term changes something where it applies.
    let f = Factors {
        base: [0.9, 0.6, 0.3],
        metallic: 0.5,
        roughness: 0.5,
        sheen: Some(([0.7, 0.5, 0.4], 0.4)),
        coat: Some((0.8, 0.3)),
        specular: (0.7, [1.4, 1.0, 0.8], 1.5),
    };
    // The roughness floor shows on a near-mirror only.
    let mirror = Factors {
        roughness: 0.02,
        coat: None,
        ..f
    };
    let dfg = Dfg((0..256).map(|_| [0.5, 0.2]).collect());
    let px: Vec<(usize, usize, Pixel)> = (0..SIZE)
        .flat_map(|y| (0..SIZE).map(move |x| (x, y)))
        .filter_map(|(x, y)| pixel(x as f64 + 0.5, y as f64 + 0.5).map(|p| (x, y, p)))
        .collect();
    for t in TERMS {
        let f = if t == Term::MinRoughness { &mirror } else { &f };
        let spec = reimplemented(f, &dfg, &px, &[]);
        let one = reimplemented(f, &dfg, &px, &[t]);
        assert!(rel_rms(&one, &spec) > 1e-4, "{t:?} changes nothing");
    }
    assert_eq!(half(0x3c00), 1.0);
    assert_eq!(half(0x3555), 0.333251953125);
    assert!((dfg.ess(0.3, 0.7) - 0.7).abs() < 1e-12);
}
