//! 3MF packages (the 3MF core specification, written directly): a zip of three XML parts —
//! `[Content_Types].xml`, `_rels/.rels` and `3D/3dmodel.model` — with the model in
//! millimetres, model-level metadata (the core's `Title`, `Designer`, `Application`,
//! `Description` and our own `ys:` names in a declared namespace), one `basematerials` group
//! and one object per mesh, each with its base material, each placed by one build item at the
//! mesh's own coordinates.
//!
//! The `threemf` crate puts `basematerials` in the materials-extension namespace after the
//! objects that use it and cannot declare a namespace for custom metadata, so it cannot say what
//! a slicer needs here. Shared by [`crate::panel`] (two objects, two materials) and
//! [`crate::parts`] (one object per part).

use std::fmt::Write as _;
use std::io::{Seek, Write};

use crate::mesh::Mesh;

/// The 3MF core namespace.
pub const CORE_NS: &str = "http://schemas.microsoft.com/3dmanufacturing/core/2015/02";
/// The namespace of our `ys:` metadata.
pub const YS_NS: &str = "https://github.com/yoshimura-space-crane/crane/fabrication";

/// A base material: its name and its display colour (`#RRGGBBAA`).
#[derive(Debug, Clone, PartialEq)]
pub struct Material {
    /// Name (what a slicer shows).
    pub name: String,
    /// sRGB display colour, `#RRGGBBAA`.
    pub colour: String,
}

/// One object: a mesh and the index of its material.
#[derive(Debug, Clone, Copy)]
pub struct Object<'a> {
    /// The solid (its name is the object's name).
    pub mesh: &'a Mesh,
    /// Index into the materials.
    pub material: usize,
}

/// A model to write.
#[derive(Debug, Clone)]
pub struct Model<'a> {
    /// Metadata (name, value), in order.
    pub metadata: Vec<(String, String)>,
    /// Base materials.
    pub materials: Vec<Material>,
    /// Objects, each placed once in the build.
    pub objects: Vec<Object<'a>>,
}

impl Model<'_> {
    /// Writes the package.
    pub fn write<W: Write + Seek>(&self, out: W) -> std::io::Result<()> {
        if let Some(o) = self
            .objects
            .iter()
            .find(|o| o.material >= self.materials.len())
        {
            return Err(std::io::Error::other(format!(
                "3MF object '{}' names material {} of {}",
                o.mesh.name,
                o.material,
                self.materials.len()
            )));
        }
        let mut zip = zip::ZipWriter::new(out);
        let opts = zip::write::SimpleFileOptions::default()
            .compression_method(zip::CompressionMethod::Deflated)
            .last_modified_time(zip::DateTime::default());
        let zerr = |e: zip::result::ZipError| std::io::Error::other(e.to_string());
        zip.start_file("[Content_Types].xml", opts).map_err(zerr)?;
        zip.write_all(CONTENT_TYPES.as_bytes())?;
        zip.start_file("_rels/.rels", opts).map_err(zerr)?;
        zip.write_all(RELS.as_bytes())?;
        zip.start_file("3D/3dmodel.model", opts).map_err(zerr)?;
        zip.write_all(self.xml().as_bytes())?;
        zip.finish().map_err(zerr)?;
        Ok(())
    }

    /// The package written to memory.
    pub fn to_bytes(&self) -> std::io::Result<Vec<u8>> {
        let mut buf = std::io::Cursor::new(Vec::new());
        self.write(&mut buf)?;
        Ok(buf.into_inner())
    }

    /// The text of `3D/3dmodel.model`.
    pub fn xml(&self) -> String {
        let mut s = String::new();
        s += r#"<?xml version="1.0" encoding="UTF-8"?>"#;
        s += "\n";
        let _ = writeln!(
            s,
            r#"<model unit="millimeter" xml:lang="en-US" xmlns="{CORE_NS}" xmlns:ys="{YS_NS}">"#
        );
        for (k, v) in &self.metadata {
            let _ = writeln!(s, r#" <metadata name="{}">{}</metadata>"#, esc(k), esc(v));
        }
        s += " <resources>\n";
        s += "  <basematerials id=\"1\">\n";
        for m in &self.materials {
            let _ = writeln!(
                s,
                r#"   <base name="{}" displaycolor="{}"/>"#,
                esc(&m.name),
                esc(&m.colour)
            );
        }
        s += "  </basematerials>\n";
        for (id, o) in self.objects.iter().enumerate() {
            let _ = writeln!(
                s,
                r#"  <object id="{}" type="model" name="{}" pid="1" pindex="{}">"#,
                id + 2,
                esc(&o.mesh.name),
                o.material
            );
            s += "   <mesh>\n    <vertices>\n";
            for v in &o.mesh.vertices {
                let _ = writeln!(
                    s,
                    r#"     <vertex x="{}" y="{}" z="{}"/>"#,
                    num(v[0]),
                    num(v[1]),
                    num(v[2])
                );
            }
            s += "    </vertices>\n    <triangles>\n";
            for t in &o.mesh.triangles {
                let _ = writeln!(
                    s,
                    r#"     <triangle v1="{}" v2="{}" v3="{}"/>"#,
                    t[0], t[1], t[2]
                );
            }
            s += "    </triangles>\n   </mesh>\n  </object>\n";
        }
        s += " </resources>\n <build>\n";
        for id in 0..self.objects.len() {
            let _ = writeln!(s, "  <item objectid=\"{}\"/>", id + 2);
        }
        s += " </build>\n</model>\n";
        s
    }
}

/// A coordinate: rounded to 1e-6 mm, shortest decimal, no `-0`.
fn num(x: f64) -> String {
    let r = (x * 1e6).round() / 1e6;
    format!("{}", if r == 0.0 { 0.0 } else { r })
}

/// XML-escapes text and attribute values.
pub fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

const CONTENT_TYPES: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<Types xmlns="http://schemas.openxmlformats.org/package/2006/content-types">
 <Default Extension="rels" ContentType="application/vnd.openxmlformats-package.relationships+xml"/>
 <Default Extension="model" ContentType="application/vnd.ms-package.3dmanufacturing-3dmodel+xml"/>
</Types>
"#;

const RELS: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<Relationships xmlns="http://schemas.openxmlformats.org/package/2006/relationships">
 <Relationship Target="/3D/3dmodel.model" Id="rel0" Type="http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"/>
</Relationships>
"#;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coordinates_are_rounded_to_a_micrometre_without_negative_zero() {
        assert_eq!(num(-1e-9), "0");
        assert_eq!(num(1.23456789), "1.234568");
        assert_eq!(num(-2.5), "-2.5");
        assert_eq!(esc(r#"a<b & "c">"#), "a&lt;b &amp; &quot;c&quot;&gt;");
    }

    #[test]
    fn an_object_naming_a_missing_material_is_refused() {
        let mesh = Mesh::new("m");
        let model = Model {
            metadata: Vec::new(),
            materials: Vec::new(),
            objects: vec![Object {
                mesh: &mesh,
                material: 0,
            }],
        };
        assert!(model.to_bytes().is_err());
    }
}
