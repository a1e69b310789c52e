//! 3D models of a stack in given states: every face of the pattern where the geometry crate
//! puts it ([`crate::folded::fold`]), coloured by module and reddened by strain.
//!
//! Colour of a face: its module's palette colour, blended towards red by its strain s (the
//! largest relative edge-length error against the flat pattern): t = min(s / 5 %, 1). Faces of
//! feasible states (s ≲ 1e-12) keep the module colour; a 6.6 % pop-out residual is pure red.
//!
//! Files: binary glTF 2.0 (`gltf-json` builds the document, `gltf`'s `Glb` writes the container
//! and its reader validates the result; metres, +Y up as the specification requires), OBJ
//! with per-vertex colours (mm, +Z up), binary STL (mm, +Z up, no colours).

use std::borrow::Cow;
use std::collections::BTreeMap;

use gltf_json as json;
use json::validation::Checked::Valid;
use json::validation::USize64;

use crate::folded::{Folded, LayerState};
use crate::mesh::Mesh;
use crate::pattern::Pattern;

/// Strain at which a face is drawn pure red.
pub const STRAIN_FULL_RED: f64 = 0.05;

/// Module colours (sRGB), cycled for more modules.
pub const PALETTE: [[u8; 3]; 8] = [
    [0x4c, 0x72, 0xb0],
    [0xdd, 0x84, 0x52],
    [0x55, 0xa8, 0x68],
    [0x81, 0x72, 0xb3],
    [0x93, 0x78, 0x60],
    [0xda, 0x8b, 0xc3],
    [0x8c, 0x8c, 0x8c],
    [0xcc, 0xb9, 0x74],
];

fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// sRGB colour (0–1) of a face of `module` with strain `strain`.
pub fn face_colour(module: usize, strain: f64) -> [f32; 3] {
    let base = PALETTE[module % PALETTE.len()].map(|c| c as f32 / 255.0);
    let t = (strain / STRAIN_FULL_RED).clamp(0.0, 1.0) as f32;
    let red = [0.9, 0.05, 0.05];
    [0, 1, 2].map(|k| base[k] * (1.0 - t) + red[k] * t)
}

/// A folded stack as a coloured triangle soup (mm, +Z up: the trunk's axis).
#[derive(Debug, Clone)]
pub struct Model {
    /// Triangles with sRGB colours in `colours` (alpha 1).
    pub mesh: Mesh,
    /// Largest face strain.
    pub max_strain: f64,
    /// Layer states, bottom first.
    pub states: Vec<LayerState>,
    /// Whether every layer's state is feasible.
    pub feasible: bool,
}

impl Model {
    /// The model of `pattern` folded as `folded`.
    pub fn new(pattern: &Pattern, folded: &Folded) -> Self {
        let l = pattern.trunk().edge_mm();
        let mut mesh = Mesh::new("Yoshimura trunk");
        for (f, &s) in pattern.faces.iter().zip(&folded.face_strain) {
            let p = f.v.map(|v| {
                let q = folded.coords[v];
                [q.x * l, q.y * l, q.z * l]
            });
            let c = face_colour(f.module, s);
            mesh.triangle(p[0], p[1], p[2], Some([c[0], c[1], c[2], 1.0]));
        }
        Model {
            mesh,
            max_strain: folded.max_strain,
            states: folded.states.clone(),
            feasible: folded.feasible,
        }
    }

    fn title(&self) -> String {
        let states: Vec<String> = self.states.iter().map(|s| s.to_string()).collect();
        format!(
            "Yoshimura stack, layer states (bottom first) {}; largest strain {:.3e}{}",
            states.join(","),
            self.max_strain,
            if self.feasible { "" } else { " (infeasible)" }
        )
    }

    /// Binary glTF 2.0 bytes (metres, +Y up: (x, y, z)_mm ↦ (x, z, −y)/1000).
    pub fn glb(&self, generator: &str) -> Result<Vec<u8>, String> {
        let to_gltf =
            |p: [f64; 3]| [p[0] / 1000.0, p[2] / 1000.0, -p[1] / 1000.0].map(|x| x as f32);
        let mut positions: Vec<f32> = Vec::new();
        let mut colours: Vec<f32> = Vec::new();
        let (mut lo, mut hi) = ([f32::MAX; 3], [f32::MIN; 3]);
        for (t, c) in self.mesh.triangles.iter().zip(&self.mesh.colours) {
            for &v in t {
                let p = to_gltf(self.mesh.vertices[v as usize]);
                for k in 0..3 {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
                positions.extend(p);
                // COLOR_0 is linear.
                colours.extend([
                    srgb_to_linear(c[0]),
                    srgb_to_linear(c[1]),
                    srgb_to_linear(c[2]),
                    1.0,
                ]);
            }
        }
        let count = positions.len() / 3;
        if count == 0 {
            return Err("the model has no faces".into());
        }
        let mut bin: Vec<u8> = Vec::with_capacity(4 * (positions.len() + colours.len()));
        for x in positions.iter().chain(&colours) {
            bin.extend(x.to_le_bytes());
        }
        let pos_len = 4 * positions.len();
        let mut root = json::Root {
            asset: json::Asset {
                generator: Some(generator.to_string()),
                version: "2.0".to_string(),
                ..Default::default()
            },
            ..Default::default()
        };
        let buffer = root.push(json::Buffer {
            byte_length: USize64::from(bin.len()),
            extensions: Default::default(),
            extras: Default::default(),
            name: None,
            uri: None,
        });
        let view = |root: &mut json::Root, offset: usize, length: usize| {
            root.push(json::buffer::View {
                buffer,
                byte_length: USize64::from(length),
                byte_offset: Some(USize64::from(offset)),
                byte_stride: None,
                extensions: Default::default(),
                extras: Default::default(),
                name: None,
                target: Some(Valid(json::buffer::Target::ArrayBuffer)),
            })
        };
        let pos_view = view(&mut root, 0, pos_len);
        let col_view = view(&mut root, pos_len, bin.len() - pos_len);
        let accessor = |root: &mut json::Root, v, ty, min, max| {
            root.push(json::Accessor {
                buffer_view: Some(v),
                byte_offset: Some(USize64(0)),
                count: USize64::from(count),
                component_type: Valid(json::accessor::GenericComponentType(
                    json::accessor::ComponentType::F32,
                )),
                extensions: Default::default(),
                extras: Default::default(),
                type_: Valid(ty),
                min,
                max,
                name: None,
                normalized: false,
                sparse: None,
            })
        };
        let pos = accessor(
            &mut root,
            pos_view,
            json::accessor::Type::Vec3,
            Some(json::Value::from(lo.to_vec())),
            Some(json::Value::from(hi.to_vec())),
        );
        let col = accessor(&mut root, col_view, json::accessor::Type::Vec4, None, None);
        let material = root.push(json::Material {
            double_sided: true,
            name: Some("sheet (vertex colours: module, red = strain)".into()),
            pbr_metallic_roughness: json::material::PbrMetallicRoughness {
                metallic_factor: json::material::StrengthFactor(0.0),
                roughness_factor: json::material::StrengthFactor(0.8),
                ..Default::default()
            },
            ..Default::default()
        });
        let mut attributes = BTreeMap::new();
        attributes.insert(Valid(json::mesh::Semantic::Positions), pos);
        attributes.insert(Valid(json::mesh::Semantic::Colors(0)), col);
        let mesh = root.push(json::Mesh {
            extensions: Default::default(),
            extras: Default::default(),
            name: Some("trunk".into()),
            primitives: vec![json::mesh::Primitive {
                attributes,
                extensions: Default::default(),
                extras: Default::default(),
                indices: None,
                material: Some(material),
                mode: Valid(json::mesh::Mode::Triangles),
                targets: None,
            }],
            weights: None,
        });
        let node = root.push(json::Node {
            mesh: Some(mesh),
            name: Some(self.title()),
            ..Default::default()
        });
        let scene = root.push(json::Scene {
            extensions: Default::default(),
            extras: Default::default(),
            name: Some("stack".into()),
            nodes: vec![node],
        });
        root.scene = Some(scene);
        let text = json::serialize::to_string(&root).map_err(|e| e.to_string())?;
        let glb = gltf::binary::Glb {
            header: gltf::binary::Header {
                magic: *b"glTF",
                version: 2,
                length: 0, // to_vec computes the real length
            },
            json: Cow::Owned(text.into_bytes()),
            bin: Some(Cow::Owned(bin)),
        };
        let bytes = glb.to_vec().map_err(|e| e.to_string())?;
        validate_glb(&bytes)?;
        Ok(bytes)
    }

    /// OBJ with per-vertex sRGB colours (`v x y z r g b`), mm, +Z up.
    pub fn obj(&self) -> String {
        use std::fmt::Write as _;
        let mut s = format!("# {}\n# units: mm, +Z up\no trunk\n", self.title());
        for (t, c) in self.mesh.triangles.iter().zip(&self.mesh.colours) {
            for &v in t {
                let p = self.mesh.vertices[v as usize];
                let _ = writeln!(
                    s,
                    "v {:.6} {:.6} {:.6} {:.4} {:.4} {:.4}",
                    p[0], p[1], p[2], c[0], c[1], c[2]
                );
            }
        }
        for k in 0..self.mesh.triangles.len() {
            let _ = writeln!(s, "f {} {} {}", 3 * k + 1, 3 * k + 2, 3 * k + 3);
        }
        s
    }
}

/// Reads binary glTF back with the `gltf` crate (which validates the document) and checks
/// every primitive's accessors can be read; returns the number of triangles.
pub fn validate_glb(bytes: &[u8]) -> Result<usize, String> {
    let g = gltf::Gltf::from_slice(bytes).map_err(|e| format!("glTF validation: {e}"))?;
    let blob = g.blob.as_deref();
    let mut triangles = 0;
    for mesh in g.meshes() {
        for prim in mesh.primitives() {
            let reader = prim.reader(|b| match b.source() {
                gltf::buffer::Source::Bin => blob,
                gltf::buffer::Source::Uri(_) => None,
            });
            let positions: Vec<[f32; 3]> = reader
                .read_positions()
                .ok_or("primitive without positions")?
                .collect();
            let colours = reader
                .read_colors(0)
                .ok_or("primitive without COLOR_0")?
                .into_rgba_f32()
                .count();
            if !positions.len().is_multiple_of(3) || colours != positions.len() {
                return Err(format!(
                    "{} positions, {colours} colours: not whole triangles",
                    positions.len()
                ));
            }
            if positions.iter().flatten().any(|x| !x.is_finite()) {
                return Err("non-finite position".into());
            }
            triangles += positions.len() / 3;
        }
    }
    Ok(triangles)
}
