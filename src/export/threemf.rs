//! 3MF (core spec): a zip with the model at `3D/3dmodel.model`, unit millimetre. Deterministic:
//! fixed timestamps and file order.

use crate::mesh::Mesh;
use std::fmt::Write as _;
use std::io::Write as _;

const CONTENT_TYPES: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<Types xmlns="http://schemas.openxmlformats.org/package/2006/content-types"><Default Extension="rels" ContentType="application/vnd.openxmlformats-package.relationships+xml"/><Default Extension="model" ContentType="application/vnd.ms-package.3dmanufacturing-3dmodel+xml"/></Types>
"#;
const RELS: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<Relationships xmlns="http://schemas.openxmlformats.org/package/2006/relationships"><Relationship Target="/3D/3dmodel.model" Id="rel0" Type="http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"/></Relationships>
"#;

/// One object of a 3MF: its name, mesh, and whether a slicer should print it. A reference object
/// (not printable) is written with the core specification's object type `other` and without a
/// build item (the specification forbids build items of that type), so no consumer manufactures it.
pub struct Object<'a> {
    pub name: &'a str,
    pub mesh: &'a Mesh,
    pub printable: bool,
}

impl<'a> Object<'a> {
    pub fn printed(name: &'a str, mesh: &'a Mesh) -> Self {
        Object { name, mesh, printable: true }
    }
}

/// One 3MF holding each named mesh as its own object and build item.
pub fn to_bytes(objects: &[Object]) -> Vec<u8> {
    let mut xml = String::with_capacity(1 << 20);
    xml.push_str("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<model unit=\"millimeter\" xml:lang=\"en-US\" xmlns=\"http://schemas.microsoft.com/3dmanufacturing/core/2015/02\">\n<metadata name=\"Application\">tipforge</metadata>\n<resources>\n");
    for (i, Object { name, mesh, printable }) in objects.iter().enumerate() {
        let kind = if *printable { "model" } else { "other" };
        let _ = writeln!(xml, "<object id=\"{}\" name=\"{}\" type=\"{kind}\"><mesh><vertices>", i + 1, escape(name));
        for v in mesh.to_f32() {
            let _ = writeln!(xml, "<vertex x=\"{}\" y=\"{}\" z=\"{}\"/>", v[0], v[1], v[2]);
        }
        xml.push_str("</vertices><triangles>\n");
        for t in &mesh.triangles {
            let _ = writeln!(xml, "<triangle v1=\"{}\" v2=\"{}\" v3=\"{}\"/>", t[0], t[1], t[2]);
        }
        xml.push_str("</triangles></mesh></object>\n");
    }
    xml.push_str("</resources>\n<build>\n");
    // the core specification forbids build items of type `other`: reference objects are resources
    // that viewers list and slicers do not place
    for (i, _) in objects.iter().enumerate().filter(|(_, o)| o.printable) {
        let _ = writeln!(xml, "<item objectid=\"{}\"/>", i + 1);
    }
    xml.push_str("</build>\n</model>\n");

    let mut buf = std::io::Cursor::new(Vec::new());
    {
        let mut zip = zip::ZipWriter::new(&mut buf);
        let opts =
            zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Deflated).last_modified_time(zip::DateTime::default()).unix_permissions(0o644);
        for (name, data) in [("[Content_Types].xml", CONTENT_TYPES.as_bytes()), ("_rels/.rels", RELS.as_bytes()), ("3D/3dmodel.model", xml.as_bytes())] {
            zip.start_file(name, opts).expect("zip entry in memory");
            zip.write_all(data).expect("zip write in memory");
        }
        zip.finish().expect("zip finish in memory");
    }
    buf.into_inner()
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Solid;

    #[test]
    fn model_part_is_where_readers_look_and_is_deterministic() {
        let m = Solid::cuboid([0.0; 3], [1.0; 3]).to_mesh();
        let a = to_bytes(&[Object::printed("cube", &m)]);
        let b = to_bytes(&[Object::printed("cube", &m)]);
        assert_eq!(a, b);
        let mut z = zip::ZipArchive::new(std::io::Cursor::new(a)).unwrap();
        let mut s = String::new();
        std::io::Read::read_to_string(&mut z.by_name("3D/3dmodel.model").unwrap(), &mut s).unwrap();
        assert!(s.contains("unit=\"millimeter\""));
        assert_eq!(s.matches("<triangle ").count(), m.triangles.len());
    }

    #[test]
    fn reference_objects_are_type_other() {
        let m = Solid::cuboid([0.0; 3], [1.0; 3]).to_mesh();
        let a = to_bytes(&[Object::printed("part", &m), Object { name: "sensor (reference)", mesh: &m, printable: false }]);
        let mut z = zip::ZipArchive::new(std::io::Cursor::new(a)).unwrap();
        let mut s = String::new();
        std::io::Read::read_to_string(&mut z.by_name("3D/3dmodel.model").unwrap(), &mut s).unwrap();
        assert!(s.contains(r#"name="part" type="model""#) && s.contains(r#"name="sensor (reference)" type="other""#), "{s}");
        assert!(s.contains(r#"<item objectid="1"/>"#) && !s.contains(r#"<item objectid="2"/>"#), "{s}");
    }
}
