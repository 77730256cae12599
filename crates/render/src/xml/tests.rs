//! Loader tests: each writes its files into its own temporary directory.

use super::*;
use crate::scene::{Bsdf, FovAxis, Geometry, Scene};
use glam::Vec3;
use std::path::PathBuf;

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("linlight-xml-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn write(d: &std::path::Path, name: &str, data: impl AsRef<[u8]>) -> PathBuf {
    let p = d.join(name);
    if let Some(parent) = p.parent() {
        std::fs::create_dir_all(parent).unwrap();
    }
    std::fs::write(&p, data).unwrap();
    p
}

const SENSOR: &str = r#"<sensor type="perspective"><float name="fov" value="40"/><film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="24"/><string name="component_format" value="float32"/><rfilter type="box"/></film></sensor>"#;

/// A scene with a sensor and integrator around `body`.
pub(super) fn wrap(body: &str) -> String {
    format!(
        "<scene version=\"3.0.0\">\n<integrator type=\"direct\"/>\n{SENSOR}\n{body}\n</scene>\n"
    )
}

fn load_in(name: &str, xml: &str, overrides: &[(&str, &str)]) -> Result<Scene, SceneError> {
    let d = dir(name);
    let p = write(&d, "scene.xml", xml);
    let o: Vec<(String, String)> = overrides
        .iter()
        .map(|(a, b)| (a.to_string(), b.to_string()))
        .collect();
    load_scene(&p, &o)
}

pub(super) fn load(name: &str, body: &str) -> Scene {
    load_in(name, &wrap(body), &[]).unwrap_or_else(|e| panic!("{e}"))
}

fn load_err(name: &str, xml: &str) -> String {
    match load_in(name, xml, &[]) {
        Ok(_) => panic!("{name}: expected an error"),
        Err(e) => e.to_string(),
    }
}

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).length() < 1e-5
}

fn mesh(s: &Scene, i: usize) -> (&Vec<Vec3>, &Option<Vec<Vec3>>, &Vec<[u32; 3]>) {
    match &s.shapes[i].geometry {
        Geometry::Mesh {
            positions,
            normals,
            indices,
        } => (positions, normals, indices),
        g => panic!("not a mesh: {g:?}"),
    }
}

fn face_normal(p: &[Vec3], t: [u32; 3]) -> Vec3 {
    let (a, b, c) = (p[t[0] as usize], p[t[1] as usize], p[t[2] as usize]);
    (b - a).cross(c - a).normalize()
}

fn sphere(s: &Scene, i: usize) -> (Vec3, f32) {
    match &s.shapes[i].geometry {
        Geometry::Sphere { center, radius } => (*center, *radius),
        g => panic!("not a sphere: {g:?}"),
    }
}

#[test]
fn defaults_and_hash() {
    let xml = "<scene version=\"3.0.0\">\n<integrator type=\"direct\"/>\n<sensor type=\"perspective\">\n<float name=\"fov\" value=\"30\"/>\n<film type=\"hdrfilm\"><string name=\"component_format\" value=\"float32\"/><rfilter type=\"box\"/></film>\n</sensor>\n</scene>\n";
    let d = dir("defaults");
    let p = write(&d, "scene.xml", xml);
    let s = load_scene(&p, &[]).unwrap();
    assert_eq!((s.sensor.film.width, s.sensor.film.height), (768, 576));
    assert_eq!(s.sensor.film.crop, None);
    assert_eq!(s.sensor.fov_axis, FovAxis::X);
    assert_eq!(s.sensor.fov_deg, 30.0);
    assert_eq!((s.sensor.sample_count, s.sensor.seed), (4, 0));
    assert!(!s.integrator.hide_emitters);
    assert_eq!((s.sensor.near_clip, s.sensor.far_clip), (1e-2, 1e4));
    assert!(s.shapes.is_empty() && s.lights.is_empty());
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    use sha2::{Digest, Sha256};
    let want: String = Sha256::digest(xml.as_bytes())
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect();
    assert_eq!(s.sha256, want);
    assert_eq!(s.sha256.len(), 64);
}

#[test]
fn missing_film_and_filter_warn() {
    let s = load_in(
        "nofilter",
        "<scene version=\"3.0.0\"><integrator type=\"direct\"/><sensor type=\"perspective\"/></scene>",
        &[],
    )
    .unwrap();
    assert_eq!((s.sensor.film.width, s.sensor.film.height), (768, 576));
    // No fov: Mitsuba's 50 mm lens, diagonal.
    assert_eq!(s.sensor.fov_axis, FovAxis::Diagonal);
    assert!(
        (s.sensor.fov_deg - 46.7930).abs() < 1e-3,
        "{}",
        s.sensor.fov_deg
    );
    assert!(s.warnings.iter().any(|w| w.contains("gaussian")));
}

#[test]
fn full_sensor() {
    let xml = r#"<scene version="3.0.0">
<integrator type="direct"><boolean name="hide_emitters" value="true"/>
  <integer name="emitter_samples" value="4"/><integer name="bsdf_samples" value="0"/></integrator>
<sensor type="perspective">
  <float name="fov" value="35"/><string name="fov_axis" value="Y"/>
  <float name="principal_point_offset_x" value="0.1"/><float name="principal_point_offset_y" value="-0.2"/>
  <float name="near_clip" value="0.5"/><float name="far_clip" value="50"/>
  <transform name="to_world"><lookat origin="1, 2, 3" target="1 2 4" up="0 1 0"/></transform>
  <film type="hdrfilm"><integer name="width" value="64"/><integer name="height" value="48"/>
    <integer name="crop_offset_x" value="8"/><integer name="crop_width" value="16"/>
    <string name="pixel_format" value="rgb"/><string name="component_format" value="float32"/>
    <string name="file_format" value="openexr"/><rfilter type="box"/></film>
  <sampler type="independent"><integer name="sample_count" value="256"/><integer name="seed" value="7"/></sampler>
</sensor>
</scene>"#;
    let s = load_in("fullsensor", xml, &[]).unwrap();
    let c = &s.sensor;
    assert!(s.integrator.hide_emitters);
    assert_eq!((c.fov_deg, c.fov_axis), (35.0, FovAxis::Y));
    assert_eq!(
        (c.principal_point_offset_x, c.principal_point_offset_y),
        (0.1, -0.2)
    );
    assert_eq!((c.near_clip, c.far_clip), (0.5, 50.0));
    assert_eq!((c.sample_count, c.seed), (256, 7));
    assert_eq!((c.film.width, c.film.height), (64, 48));
    let crop = c.film.crop.unwrap();
    assert_eq!(
        (crop.offset_x, crop.offset_y, crop.width, crop.height),
        (8, 0, 16, 48)
    );
    // Camera +x = left = normalize(up × forward) = y × z = +x; origin in the last column.
    assert!(close(c.to_world.x_axis.truncate(), Vec3::X));
    assert!(close(c.to_world.y_axis.truncate(), Vec3::Y));
    assert!(close(c.to_world.z_axis.truncate(), Vec3::Z));
    assert!(close(
        c.to_world.w_axis.truncate(),
        Vec3::new(1.0, 2.0, 3.0)
    ));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
}

#[test]
fn lookat_matches_mitsuba_convention() {
    // Camera at (0, 0, 5) looking at the origin with up +y: forward −z,
    // left = y × (−z) = −x, up' = forward × left = +y.
    let xml = wrap("")
        .replace(
            r#"<float name="fov" value="40"/>"#,
            r#"<float name="fov" value="40"/><transform name="to_world"><lookat origin="0,0,5" target="0,0,0" up="0,1,0"/></transform>"#,
        );
    let s = load_in("lookat", &xml, &[]).unwrap();
    let m = s.sensor.to_world;
    assert!(close(m.x_axis.truncate(), -Vec3::X));
    assert!(close(m.y_axis.truncate(), Vec3::Y));
    assert!(close(m.z_axis.truncate(), -Vec3::Z));
    assert!(close(
        m.transform_point3(Vec3::ZERO),
        Vec3::new(0.0, 0.0, 5.0)
    ));
    // A tilted up vector is orthogonalised: left stays unit and ⊥ forward.
    let xml = wrap("").replace(
        r#"<float name="fov" value="40"/>"#,
        r#"<float name="fov" value="40"/><transform name="to_world"><lookat origin="0,0,0" target="1,0,0" up="0.3,1,0"/></transform>"#,
    );
    let m = load_in("lookat2", &xml, &[]).unwrap().sensor.to_world;
    assert!(close(m.z_axis.truncate(), Vec3::X));
    assert!(close(
        m.x_axis.truncate(),
        Vec3::new(0.3, 1.0, 0.0).cross(Vec3::X).normalize()
    ));
    assert!(close(m.y_axis.truncate(), Vec3::Y));
}

#[test]
fn transform_order() {
    // translate then rotate: R·T·0 = R·(1,0,0) = (0,1,0).
    let s = load(
        "order1",
        r#"<shape type="sphere"><float name="radius" value="0.5"/><transform name="to_world">
             <translate x="1"/><rotate z="1" angle="90"/></transform></shape>
           <shape type="sphere"><float name="radius" value="0.5"/><transform name="to_world">
             <rotate value="0 0 1" angle="90"/><translate value="1 0 0"/></transform></shape>
           <shape type="sphere"><transform name="to_world">
             <scale value="2"/><translate x="1" y="2" z="3"/></transform></shape>
           <shape type="sphere"><transform name="to_world">
             <matrix value="1 0 0 5  0 1 0 6  0 0 1 7  0 0 0 1"/></transform></shape>
           <shape type="sphere"><point name="center" x="1"/><float name="radius" value="0.25"/>
             <transform name="to_world"><scale value="2"/></transform></shape>"#,
    );
    assert_eq!(s.shapes.len(), 5);
    assert!(close(sphere(&s, 0).0, Vec3::new(0.0, 1.0, 0.0)));
    assert!(close(sphere(&s, 1).0, Vec3::new(1.0, 0.0, 0.0)));
    let (c, r) = sphere(&s, 2);
    assert!(close(c, Vec3::new(1.0, 2.0, 3.0)) && (r - 2.0).abs() < 1e-6);
    assert!(close(sphere(&s, 3).0, Vec3::new(5.0, 6.0, 7.0)));
    let (c, r) = sphere(&s, 4);
    assert!(close(c, Vec3::new(2.0, 0.0, 0.0)) && (r - 0.5).abs() < 1e-6);
}

#[test]
fn substitution_defaults_and_overrides() {
    let xml = r#"<scene version="3.0.0">
<default name="s" value="1"/>
<default name="spp" value="16"/>
<default name="w" value="$s$s"/>
<integrator type="direct"/>
<sensor type="perspective"><float name="fov" value="40"/>
  <film type="hdrfilm"><integer name="width" value="$w"/><integer name="height" value="$s"/><string name="component_format" value="float32"/><rfilter type="box"/></film>
  <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
</sensor>
</scene>"#;
    let s = load_in("subst", xml, &[]).unwrap();
    // "$spp" is replaced before "$s" (longest names first).
    assert_eq!(s.sensor.sample_count, 16);
    assert_eq!((s.sensor.film.width, s.sensor.film.height), (11, 1));
    let s = load_in("subst2", xml, &[("spp", "64"), ("s", "2")]).unwrap();
    assert_eq!(s.sensor.sample_count, 64);
    assert_eq!((s.sensor.film.width, s.sensor.film.height), (22, 2));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    // Mitsuba 3.9: "Found unused parameters" for a name never substituted, for the second of
    // two overrides of one name, and for an override whose only use is a <default>.
    for (case, overrides, unused) in [
        ("subst3", &[("nothing", "1")][..], "$nothing=1"),
        ("subst3b", &[("s", "3"), ("s", "2")][..], "$s=2"),
        ("subst3c", &[("w", "5")][..], "$w=5"),
    ] {
        let e = load_in(case, &xml.replace("$w\"/>", "7\"/>"), overrides)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("found unused parameters: ") && e.contains(unused),
            "{case}: {e}"
        );
    }
    // The first of two overrides wins (it is the one substituted).
    let e = load_in("subst3d", xml, &[("s", "3"), ("s", "2")]).unwrap_err();
    assert!(e.to_string().contains("$s=2"), "{e}");
    // An escaped dollar is a literal '$', not a parameter.
    let e = load_in(
        "subst5",
        &wrap(r#"<shape type="obj"><string name="filename" value="a\$b.obj"/></shape>"#),
        &[],
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("a$b.obj"), "{e}");
    let e = load_in(
        "subst4",
        &wrap(r#"<shape type="sphere"><float name="radius" value="$r"/></shape>"#),
        &[],
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("scene.xml:4:22: ") && e.contains("undefined parameter"),
        "{e}"
    );
}

#[test]
fn include_and_ref() {
    let d = dir("include");
    write(
        &d,
        "parts/shapes.xml",
        r#"<scene version="3.0.0"><shape type="sphere"><ref id="red"/><float name="radius" value="$r"/></shape></scene>"#,
    );
    write(
        &d,
        "parts/bsdf.xml",
        r#"<bsdf type="diffuse" id="red" version="3.0.0"><rgb name="reflectance" value="1, 0, 0"/></bsdf>"#,
    );
    let xml = wrap(
        r#"<default name="r" value="3"/>
<include filename="parts/shapes.xml"/>
<include filename="parts/bsdf.xml"/>
<shape type="rectangle"><ref name="bsdf" id="red"/></shape>
<shape type="cube"/>"#,
    );
    let p = write(&d, "scene.xml", &xml);
    let s = load_scene(&p, &[]).unwrap();
    assert_eq!(s.shapes.len(), 3);
    let red = Bsdf::Diffuse {
        reflectance: [1.0, 0.0, 0.0],
    };
    assert_eq!(s.shapes[0].bsdf, red); // reference before definition
    assert_eq!(sphere(&s, 0).1, 3.0);
    assert!(s.shapes[0].location.file.ends_with("parts/shapes.xml"));
    assert_eq!(s.shapes[1].bsdf, red);
    // No BSDF: Mitsuba's default diffuse 0.5.
    assert_eq!(
        s.shapes[2].bsdf,
        Bsdf::Diffuse {
            reflectance: [0.5; 3]
        }
    );
    // Missing include and unknown ref.
    let p = write(&d, "bad.xml", wrap(r#"<include filename="nope.xml"/>"#));
    let e = load_scene(&p, &[]).unwrap_err().to_string();
    assert!(e.contains("bad.xml:4:1:") && e.contains("nope.xml"), "{e}");
    let p = write(
        &d,
        "bad2.xml",
        wrap(r#"<shape type="cube"><ref id="blue"/></shape>"#),
    );
    let e = load_scene(&p, &[]).unwrap_err().to_string();
    assert!(
        e.contains("bad2.xml:4:20:") && e.contains("unknown id 'blue'"),
        "{e}"
    );
}

#[test]
fn bsdfs() {
    let s = load(
        "bsdfs",
        r#"<shape type="rectangle"><bsdf type="twosided"><bsdf type="diffuse"><float name="reflectance" value="0.3"/></bsdf></bsdf></shape>
           <shape type="rectangle"><bsdf type="diffuse"><spectrum name="reflectance" value="0.2"/></bsdf></shape>
           <shape type="rectangle"><bsdf type="diffuse"><rgb name="reflectance" value="0.1 0.2 0.3"/></bsdf></shape>
           <shape type="rectangle"><bsdf type="diffuse"/></shape>"#,
    );
    assert_eq!(
        s.shapes[0].bsdf,
        Bsdf::TwoSided(Box::new(Bsdf::Diffuse {
            reflectance: [0.3; 3]
        }))
    );
    assert_eq!(
        s.shapes[1].bsdf,
        Bsdf::Diffuse {
            reflectance: [0.2; 3]
        }
    );
    assert_eq!(
        s.shapes[2].bsdf,
        Bsdf::Diffuse {
            reflectance: [0.1, 0.2, 0.3]
        }
    );
    assert_eq!(
        s.shapes[3].bsdf,
        Bsdf::Diffuse {
            reflectance: [0.5; 3]
        }
    );
}

#[test]
fn builtin_shapes() {
    let s = load(
        "shapes",
        r#"<shape type="rectangle"/>
<shape type="rectangle"><transform name="to_world"><scale x="-1"/></transform><boolean name="flip_normals" value="true"/></shape>
<shape type="cube"><transform name="to_world"><translate x="10"/></transform></shape>
<shape type="disk"><transform name="to_world"><scale value="2"/><translate z="1"/></transform></shape>
<shape type="cylinder"><point name="p0" value="0 0 0"/><point name="p1" value="0 0 2"/><float name="radius" value="0.5"/>
  <transform name="to_world"><scale value="2"/></transform></shape>"#,
    );
    let (p, n, t) = mesh(&s, 0);
    assert_eq!(t.len(), 2);
    assert!(n.is_none());
    for tri in t {
        assert!(close(face_normal(p, *tri), Vec3::Z));
    }
    assert!(p
        .iter()
        .all(|q| q.x.abs() == 1.0 && q.y.abs() == 1.0 && q.z == 0.0));
    assert!(!s.shapes[0].flip_normals);
    // Mirrored rectangle keeps Mitsuba's normal M⁻ᵀ·z = +z; flip_normals is left to the renderer.
    let (p, _, t) = mesh(&s, 1);
    assert!(close(face_normal(p, t[0]), Vec3::Z));
    assert!(s.shapes[1].flip_normals);
    let (p, n, t) = mesh(&s, 2);
    assert_eq!(t.len(), 12);
    let n = n.as_ref().unwrap();
    for tri in t {
        let fnorm = face_normal(p, *tri);
        let centroid = (p[tri[0] as usize] + p[tri[1] as usize] + p[tri[2] as usize]) / 3.0;
        assert!(fnorm.dot(centroid - Vec3::new(10.0, 0.0, 0.0)) > 0.0);
        assert!(close(n[tri[0] as usize], fnorm));
    }
    match &s.shapes[3].geometry {
        Geometry::Disk { to_world } => {
            assert!(close(
                to_world.transform_point3(Vec3::X),
                Vec3::new(2.0, 0.0, 1.0)
            ))
        }
        g => panic!("{g:?}"),
    }
    assert_eq!(
        s.shapes[4].geometry,
        Geometry::Cylinder {
            p0: Vec3::ZERO,
            p1: Vec3::new(0.0, 0.0, 4.0),
            radius: 1.0
        }
    );
}

#[test]
fn linear_light() {
    let s = load(
        "light",
        r#"<shape type="rectangle"><transform name="to_world"><scale value="5"/></transform></shape>
<shape type="cylinder"><point name="p0" value="-1 0 1"/><point name="p1" value="1 0 1"/><float name="radius" value="0.001"/>
  <transform name="to_world"><scale value="2"/><translate y="0.5"/></transform>
  <emitter type="area"><rgb name="radiance" value="100, 200, 300"/></emitter></shape>
<shape type="cylinder"><vector name="p0" value="0 0 1"/><vector name="p1" value="0 1 1"/><float name="radius" value="1e-4"/>
  <emitter type="area"><spectrum name="radiance" value="50"/></emitter></shape>"#,
    );
    assert_eq!(s.shapes.len(), 1);
    assert_eq!(s.lights.len(), 2);
    let l = &s.lights[0];
    assert!(close(l.begin, Vec3::new(-2.0, 0.5, 2.0)));
    assert!(close(l.end, Vec3::new(2.0, 0.5, 2.0)));
    assert!((l.radius - 0.002).abs() < 1e-9);
    // K = radiance × (world) radius.
    for (k, want) in l.radiance_times_radius.iter().zip([0.2, 0.4, 0.6]) {
        assert!((k - want).abs() < 1e-6, "{k} vs {want}");
    }
    assert!(s.lights[1]
        .radiance_times_radius
        .iter()
        .all(|k| (k - 0.005).abs() < 1e-8));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    assert_eq!(
        s.lights
            .iter()
            .map(|l| l.sampling_weight)
            .collect::<Vec<_>>(),
        [1.0; 2]
    );

    // A fat cylinder is reported under --cylinders line (its axis meets no surface: the
    // estimate off the axis), with the expected relative error.
    let s = load(
        "fatlight",
        r#"<shape type="rectangle"/>
<shape type="cylinder"><float name="radius" value="0.1"/><emitter type="area"/></shape>"#,
    );
    assert_eq!(s.lights[0].radiance_times_radius, [0.1; 3]); // default radiance 1
    let line = super::radius::line_limit_warnings(&s);
    assert!(
        line.iter()
            .any(|w| w.contains("(R = 0.1): up to") && w.contains("--cylinders line")),
        "{line:?}"
    );
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    // Several such lights are one warning with their count and the largest effect.
    let s = load(
        "fatlights",
        r#"<shape type="rectangle"/>
<shape type="cylinder"><float name="radius" value="0.1"/><emitter type="area"/></shape>
<shape type="cylinder"><float name="radius" value="0.05"/><emitter type="area"/></shape>
<shape type="cylinder"><float name="radius" value="0.1"/><emitter type="area"/></shape>"#,
    );
    let grouped = super::radius::line_limit_warnings(&s);
    assert_eq!(grouped.len(), 1, "{grouped:?}");
    assert!(
        grouped[0].starts_with("3 lights (R from 0.05 to 0.1), the largest effect light at ")
            && grouped[0].contains("(R = 0.1): up to")
            && grouped[0].contains("cylinders differ from the R → 0 limit"),
        "{grouped:?}"
    );
    assert_eq!(line.len(), 1, "{line:?}");
    // A radius above a quarter of the length is warned about in any mode.
    let s = load(
        "fatterlight",
        r#"<shape type="rectangle"/>
<shape type="cylinder"><float name="radius" value="0.3"/><emitter type="area"/></shape>"#,
    );
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("more than 0.25 × its length")),
        "{:?}",
        s.warnings
    );
}

/// Mitsuba's emitter `sampling_weight` is read; a weight that would never choose its light is
/// an error at the emitter.
#[test]
fn emitter_sampling_weight() {
    let tube = |w: &str| {
        format!(
            r#"<shape type="cylinder"><float name="radius" value="1e-4"/>
<emitter type="area"><float name="sampling_weight" value="{w}"/></emitter></shape>"#
        )
    };
    let s = load("weight", &tube("2.5"));
    assert_eq!(s.lights[0].sampling_weight, 2.5);
    for bad in ["0", "-1", "1e40"] {
        expect_error(
            "e_weight",
            &wrap(&tube(bad)),
            "5:1",
            "sampling_weight must be positive and finite",
        );
    }
}

fn obj_scene(d: &std::path::Path, body: &str) -> Scene {
    let p = write(d, "scene.xml", wrap(body));
    load_scene(&p, &[]).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn obj_meshes() {
    let d = dir("obj");
    // A slanted quad with normals, and a tent without.
    write(
        &d,
        "meshes/quad.obj",
        "v 0 0 0\nv 1 0 1\nv 1 1 1\nv 0 1 0\nvn -1 0 1\nf 1//1 2//1 3//1 4//1\n",
    );
    write(
        &d,
        "meshes/tent.obj",
        "o tent\nv -1 0 0\nv 0 0 1\nv 0 1 1\nv 1 0 0\nvt 0 0\nf 1 2 3\nf 2 4 3\n",
    );
    let s = obj_scene(
        &d,
        r#"<shape type="obj"><string name="filename" value="meshes/quad.obj"/>
             <transform name="to_world"><scale x="2"/></transform></shape>
           <shape type="obj"><string name="filename" value="meshes/quad.obj"/><boolean name="face_normals" value="true"/><boolean name="flip_tex_coords" value="false"/></shape>
           <shape type="obj"><string name="filename" value="meshes/tent.obj"/></shape>
           <shape type="obj"><string name="filename" value="meshes/tent.obj"/><boolean name="flip_normals" value="true"/><boolean name="face_normals" value="true"/></shape>"#,
    );
    let (p, n, t) = mesh(&s, 0);
    assert_eq!(t, &vec![[0, 1, 2], [0, 2, 3]]);
    assert!(close(p[2], Vec3::new(2.0, 1.0, 1.0)));
    // Normals transform by the inverse transpose: (−1,0,1) under scale x=2 → (−1/2, 0, 1).
    let want = Vec3::new(-0.5, 0.0, 1.0).normalize();
    assert!(n.as_ref().unwrap().iter().all(|v| close(*v, want)));
    // …and still agree with the transformed geometry.
    assert!(close(face_normal(p, t[0]), want));
    let (_, n, _) = mesh(&s, 1);
    assert!(n.is_none());
    // Missing normals are computed smoothly (angle-weighted), as Mitsuba does.
    let (_, n, t) = mesh(&s, 2);
    assert_eq!(t.len(), 2);
    let n = n.as_ref().unwrap();
    assert!(close(n[1], Vec3::Z) && close(n[2], Vec3::Z));
    let (_, n, _) = mesh(&s, 3);
    assert!(n.is_none() && s.shapes[3].flip_normals);
}

#[test]
fn ply_meshes() {
    let d = dir("ply");
    let pos = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ];
    let nrm = [[0.0, 0.0, 1.0]; 4];
    let faces = vec![vec![0, 1, 2], vec![0, 2, 3]];
    for fmt in ["ascii", "binary_little_endian"] {
        write(
            &d,
            &format!("{fmt}_n.ply"),
            ply::write_ply(fmt, &pos, Some(&nrm), &faces),
        );
        write(
            &d,
            &format!("{fmt}.ply"),
            ply::write_ply(fmt, &pos, None, &faces),
        );
        let s = obj_scene(
            &d,
            &format!(
                r#"<shape type="ply"><string name="filename" value="{fmt}_n.ply"/>
                     <transform name="to_world"><rotate x="1" angle="90"/></transform></shape>
                   <shape type="ply"><string name="filename" value="{fmt}.ply"/></shape>
                   <shape type="ply"><string name="filename" value="{fmt}_n.ply"/><boolean name="face_normals" value="true"/></shape>"#
            ),
        );
        let (p, n, t) = mesh(&s, 0);
        assert_eq!(t.len(), 2);
        // Rotating +z by 90° about x gives −y.
        assert!(close(p[2], Vec3::new(1.0, 0.0, 1.0)), "{fmt}: {:?}", p[2]);
        assert!(
            n.as_ref().unwrap().iter().all(|v| close(*v, -Vec3::Y)),
            "{fmt}"
        );
        let (_, n, _) = mesh(&s, 1);
        assert!(
            n.as_ref().unwrap().iter().all(|v| close(*v, Vec3::Z)),
            "{fmt}"
        );
        let (_, n, _) = mesh(&s, 2);
        assert!(n.is_none());
    }
}

/// Asserts that loading `xml` fails with `file:line:col: ` followed by text containing `want`.
pub(super) fn expect_error(name: &str, xml: &str, line_col: &str, want: &str) {
    let e = load_err(name, xml);
    assert!(
        e.contains(&format!("scene.xml:{line_col}: ")) && e.contains(want),
        "{name}: got '{e}', want '{line_col}' and '{want}'"
    );
}

#[test]
fn errors_name_file_line_column_and_element() {
    let scene = |body: &str| wrap(body); // body starts on line 4, column 1
    expect_error(
        "e_bsdf",
        &scene(r#"<shape type="cube"><bsdf type="roughplastic"/></shape>"#),
        "4:20",
        "unsupported bsdf type 'roughplastic' (supported: diffuse, roughconductor, principled, \
         blendbsdf, twosided)",
    );
    expect_error(
        "e_version",
        r#"<scene version="2.1.0"><integrator type="direct"/></scene>"#,
        "1:1",
        "unsupported scene version '2.1.0'",
    );
    expect_error(
        "e_noversion",
        "<scene>\n</scene>",
        "1:1",
        "missing the version",
    );
    expect_error(
        "e_malformed",
        "<scene version=\"3.0.0\">\n  <shape type=\"cube\">\n</scene>",
        "3:1",
        "malformed XML",
    );
    expect_error(
        "e_inf",
        &scene(r#"<shape type="sphere"><float name="radius" value="inf"/></shape>"#),
        "4:22",
        "non-finite number 'inf'",
    );
    expect_error(
        "e_nan",
        &scene(r#"<shape type="sphere"><point name="center" value="0 nan 0"/></shape>"#),
        "4:22",
        "non-finite",
    );
    expect_error(
        "e_emitter_on_rect",
        &scene(r#"<shape type="rectangle"><emitter type="area"/></shape>"#),
        "4:25",
        "area emitters are only supported on cylinders",
    );
    expect_error(
        "e_point_light",
        &scene(r#"<emitter type="point"/>"#),
        "4:1",
        "unsupported emitter type 'point'",
    );
    expect_error(
        "e_spot_on_cyl",
        &scene(r#"<shape type="cylinder"><emitter type="spot"/></shape>"#),
        "4:24",
        "unsupported emitter type 'spot'",
    );
    expect_error(
        "e_shape",
        &scene(r#"<shape type="serialized"/>"#),
        "4:1",
        "unsupported shape type 'serialized'",
    );
    expect_error(
        "e_unknown_prop",
        &scene(r#"<shape type="sphere"><float name="radiuss" value="1"/></shape>"#),
        "4:22",
        "unsupported property 'radiuss' (float) on shape 'sphere'",
    );
    expect_error(
        "e_texture",
        &scene(
            r#"<shape type="cube"><bsdf type="diffuse"><texture type="bitmap" name="reflectance"/></bsdf></shape>"#,
        ),
        "4:41",
        "unsupported texture type 'bitmap'",
    );
    expect_error(
        "e_spectrum",
        &scene(
            r#"<shape type="cube"><bsdf type="diffuse"><spectrum name="reflectance" value="400:0.1, 700:0.5"/></bsdf></shape>"#,
        ),
        "4:41",
        "only constant spectra",
    );
    expect_error(
        "e_nonuniform_sphere",
        &scene(
            r#"<shape type="sphere"><transform name="to_world"><scale x="2"/></transform></shape>"#,
        ),
        "4:1",
        "sphere to_world must not scale non-uniformly",
    );
    expect_error(
        "e_nonuniform_light",
        &scene(
            r#"<shape type="cylinder"><transform name="to_world"><scale x="2"/></transform><emitter type="area"/></shape>"#,
        ),
        "4:1",
        "cylinder to_world must keep the cross-section a circle perpendicular to the axis",
    );
    expect_error(
        "e_sheared_light",
        &scene(
            r#"<shape type="cylinder"><transform name="to_world"><matrix value="1 0 0.5 0 0 1 0 0 0 0 1 0 0 0 0 1"/></transform><emitter type="area"/></shape>"#,
        ),
        "4:1",
        "cylinder to_world must keep the cross-section a circle perpendicular to the axis",
    );
    let empty = std::env::temp_dir().join(format!("linlight-xml-{}-empty.obj", std::process::id()));
    std::fs::write(&empty, "").unwrap();
    expect_error(
        "e_empty_obj",
        &scene(&format!(
            r#"<shape type="obj"><string name="filename" value="{}"/></shape>"#,
            empty.display()
        )),
        "4:1",
        "contains no faces",
    );
    // Meshes are read as regular files of bounded size: a device (endless /dev/zero, empty
    // /dev/null) or a FIFO is refused before it is read.
    expect_error(
        "e_device_obj",
        &scene(r#"<shape type="obj"><string name="filename" value="/dev/zero"/></shape>"#),
        "4:19",
        "not a regular file",
    );
    expect_error(
        "e_no_samples",
        &scene("").replace(
            r#"<integrator type="direct"/>"#,
            r#"<integrator type="direct"><integer name="emitter_samples" value="0"/><integer name="bsdf_samples" value="0"/></integrator>"#,
        ),
        "2:1",
        "at least 1 BSDF or emitter sample",
    );
    expect_error(
        "e_rotate_axis",
        &scene(
            r#"<shape type="cube"><transform name="to_world"><rotate value="1 1 0" angle="3"/></transform></shape>"#,
        ),
        "4:47",
        "must have unit length",
    );
    expect_error(
        "e_dup_id",
        &scene("<bsdf type=\"diffuse\" id=\"a\"/>\n<bsdf type=\"diffuse\" id=\"a\"/>"),
        "5:1",
        "duplicate id 'a' (previous at",
    );
    expect_error(
        "e_missing_obj",
        &scene(r#"<shape type="obj"><string name="filename" value="missing.obj"/></shape>"#),
        "4:19",
        "cannot read mesh file",
    );
    expect_error(
        "e_unknown_tag",
        &scene(r#"<medum type="homogeneous"/>"#),
        "4:1",
        "unsupported element <medum>",
    );
    expect_error(
        "e_op_outside",
        &scene(r#"<shape type="cube"><translate x="1"/></shape>"#),
        "4:20",
        "<translate> can only occur inside a <transform>",
    );
    expect_error(
        "e_bool",
        &scene(r#"<shape type="cube"><boolean name="flip_normals" value="yes"/></shape>"#),
        "4:20",
        "must be true or false",
    );
    expect_error(
        "e_type",
        &scene(r#"<shape type="sphere"><string name="radius" value="1"/></shape>"#),
        "4:22",
        "property 'radius' of shape 'sphere' must be a float (got string)",
    );
}

#[test]
fn sensor_errors() {
    let sensor = |inner: &str| {
        format!("<scene version=\"3.0.0\">\n<integrator type=\"direct\"/>\n<sensor type=\"perspective\">\n{inner}\n</sensor>\n</scene>")
    };
    expect_error(
        "s_filter",
        &sensor(r#"<film type="hdrfilm"><rfilter type="gaussian"/></film>"#),
        "4:22",
        "unsupported rfilter type 'gaussian'",
    );
    expect_error(
        "s_zero",
        &sensor(
            r#"<film type="hdrfilm"><integer name="width" value="0"/><rfilter type="box"/></film>"#,
        ),
        "4:1",
        "film size 0×576 is empty",
    );
    expect_error(
        "s_crop",
        &sensor(
            r#"<film type="hdrfilm"><integer name="width" value="10"/><integer name="crop_offset_x" value="5"/><integer name="crop_width" value="6"/><rfilter type="box"/></film>"#,
        ),
        "4:1",
        "invalid crop window",
    );
    expect_error(
        "s_sampler",
        &sensor(r#"<sampler type="stratified"/>"#),
        "4:1",
        "unsupported sampler type 'stratified' (supported: independent)",
    );
    expect_error(
        "s_spp",
        &sensor(
            r#"<sampler type="independent"><integer name="sample_count" value="0"/></sampler>"#,
        ),
        "4:29",
        "sample_count",
    );
    expect_error(
        "s_prop",
        &sensor(r#"<float name="aperture_radius" value="3"/>"#),
        "4:1",
        "unsupported property 'aperture_radius' (float) on sensor 'perspective'",
    );
    expect_error(
        "s_scale",
        &sensor(r#"<transform name="to_world"><scale value="2"/></transform>"#),
        "3:1",
        "scale factors",
    );
    expect_error(
        "s_fov",
        &sensor(r#"<float name="fov" value="180"/>"#),
        "3:1",
        "horizontal field of view",
    );
    expect_error(
        "s_axis",
        &sensor(r#"<float name="fov" value="40"/><string name="fov_axis" value="z"/>"#),
        "4:31",
        "fov_axis must be",
    );
    expect_error(
        "s_type",
        "<scene version=\"3.0.0\">\n<integrator type=\"direct\"/>\n<sensor type=\"thinlens\"/>\n</scene>",
        "3:1",
        "unsupported sensor type 'thinlens'",
    );
    expect_error(
        "s_integrator",
        "<scene version=\"3.0.0\">\n<integrator type=\"path\"/>\n</scene>",
        "2:1",
        "unsupported integrator type 'path' (supported: direct; write <integrator \
         type=\"direct\"/>",
    );
    expect_error(
        "s_nointegrator",
        "<scene version=\"3.0.0\">\n</scene>",
        "1:1",
        "no integrator",
    );
}

#[test]
fn mesh_file_errors() {
    let d = dir("meshfile");
    write(&d, "bad.obj", "v 0 0 0\nv 1 0 0\nf 1 2 3\n");
    write(
        &d,
        "bad.ply",
        "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nend_header\n",
    );
    let p = write(
        &d,
        "scene.xml",
        wrap(r#"<shape type="obj"><string name="filename" value="bad.obj"/></shape>"#),
    );
    let e = load_scene(&p, &[]).unwrap_err().to_string();
    assert!(
        e.contains("scene.xml:4:1: error loading OBJ file") && e.contains("line 3"),
        "{e}"
    );
    let p = write(
        &d,
        "scene.xml",
        wrap(r#"<shape type="ply"><string name="filename" value="bad.ply"/></shape>"#),
    );
    let e = load_scene(&p, &[]).unwrap_err().to_string();
    assert!(
        e.contains("scene.xml:4:1: error loading PLY file") && e.contains("lacks x, y or z"),
        "{e}"
    );
    let e = load_scene(&d.join("nonexistent.xml"), &[])
        .unwrap_err()
        .to_string();
    assert!(e.contains("nonexistent.xml"), "{e}");
}

/// Numbers printed by Mitsuba 3.9.1 (`scalar_rgb`, `mi.load_file` + `mi.traverse`) for the same
/// scene: camera world transform, angle-weighted normals of a mesh without normals, inverse-
/// transpose normals under a sheared to_world, sphere and cylinder placement.
#[test]
fn matches_mitsuba_3_9_1() {
    let d = dir("mitsuba");
    write(
        &d,
        "tent.obj",
        "v -1 0 0\nv 0 0 1\nv 0 1 1\nv 1 0 0\nv 0.5 2 0.3\nf 1 2 3\nf 2 4 3\nf 3 4 5\n",
    );
    write(
        &d,
        "quad.obj",
        "v 0 0 0\nv 1 0 1\nv 1 1 1\nv 0 1 0\nvn -1 0 1\nvn 0 1 1\nf 1//1 2//2 3//1 4//2\n",
    );
    let xml = r#"<scene version="3.0.0">
  <integrator type="direct"/>
  <sensor type="perspective"><float name="fov" value="33"/>
    <transform name="to_world">
      <lookat origin="1, 2, 3" target="0, 0.2, 0" up="0, 0, 1"/>
      <rotate y="1" angle="20"/>
      <translate x="0.5" y="-1" z="2"/>
    </transform>
    <film type="hdrfilm"><rfilter type="box"/></film>
  </sensor>
  <shape type="obj"><string name="filename" value="tent.obj"/>
    <transform name="to_world"><scale x="2" y="0.5" z="1"/><rotate x="0.6" y="0.8" angle="30"/><translate z="1"/></transform></shape>
  <shape type="obj"><string name="filename" value="quad.obj"/>
    <transform name="to_world"><rotate z="1" angle="45"/><scale x="3" y="1" z="0.5"/><matrix value="1 0.2 0 1  0 1 0 2  0.1 0 1 3  0 0 0 1"/></transform></shape>
  <shape type="sphere"><point name="center" x="1" y="2" z="3"/><float name="radius" value="0.5"/>
    <transform name="to_world"><rotate z="1" angle="90"/><scale value="2"/></transform></shape>
  <shape type="cylinder"><point name="p0" value="0 0 0"/><point name="p1" value="1 1 0"/><float name="radius" value="0.01"/>
    <transform name="to_world"><rotate x="1" angle="90"/><scale value="3"/><translate y="1"/></transform>
    <emitter type="area"><rgb name="radiance" value="2 3 4"/></emitter></shape>
  <shape type="rectangle"><transform name="to_world"><lookat origin="0,0,0" target="0,-1,0.2"/></transform></shape>
</scene>"#;
    let p = write(&d, "scene.xml", xml);
    let s = load_scene(&p, &[]).unwrap();
    let near = |a: Vec3, b: [f32; 3]| (a - Vec3::from(b)).abs().max_element() < 1e-4;
    // Rows of Mitsuba's camera-to-world matrix.
    let m = s.sensor.to_world.transpose();
    assert!(near(m.x_axis.truncate(), [0.82144, -0.1827, -0.54024]));
    assert!(near(m.y_axis.truncate(), [-0.48564, -0.72072, -0.49468]));
    assert!(near(m.z_axis.truncate(), [-0.29898, 0.66872, -0.68076]));
    assert!(near(
        s.sensor.to_world.w_axis.truncate(),
        [2.46575, 1.0, 4.47706]
    ));
    let (pos, n, t) = mesh(&s, 0);
    assert_eq!(t, &vec![[0, 1, 2], [1, 3, 2], [2, 3, 4]]);
    assert!(near(pos[4], [1.09856, 0.92608, 1.15981]));
    let n = n.as_ref().unwrap();
    let want = [
        [-0.0511, -0.29709, 0.95348],
        [0.4, -0.3, 0.86603],
        [0.49319, -0.24622, 0.83435],
        [0.78967, -0.0736, 0.6091],
        [0.79262, -0.00827, 0.60967],
    ];
    for (a, b) in n.iter().zip(want) {
        assert!(near(*a, b), "{a} vs {b:?}");
    }
    let (pos, n, _) = mesh(&s, 1);
    assert!(near(pos[1], [3.26274, 2.70711, 3.71213]));
    let n = n.as_ref().unwrap();
    assert!(near(n[0], [-0.20372, -0.28988, 0.93513]));
    assert!(near(n[1], [-0.19844, 0.36174, 0.91091]));
    let (c, r) = sphere(&s, 2);
    assert!(near(c, [-4.0, 2.0, 6.0]) && (r - 1.0).abs() < 1e-6);
    // Rectangle from a lookat without 'up': Mitsuba's to_world columns are
    // x = (0, −0.19612, −0.98058), y = (1, 0, 0), z = (0, −0.98058, 0.19612).
    let (pos, _, t) = mesh(&s, 3);
    assert!(near(pos[0], [-1.0, 0.19612, 0.98058]));
    assert!(near(face_normal(pos, t[0]), [0.0, -0.98058, 0.19612]));
    // Cylinder: translation (0,1,0), axis column (3,0,3), radius |column 0| = 0.03.
    let l = &s.lights[0];
    assert!(near(l.begin, [0.0, 1.0, 0.0]) && near(l.end, [3.0, 1.0, 3.0]));
    assert!((l.radius - 0.03).abs() < 1e-7);
    assert!(near(
        Vec3::from(l.radiance_times_radius),
        [0.06, 0.09, 0.12]
    ));
}

#[test]
fn no_sensor_uses_mitsuba_defaults() {
    let s = load_in(
        "nosensor",
        "<scene version=\"3.0.0\"><integrator type=\"direct\"/><shape type=\"cube\"/></scene>",
        &[],
    )
    .unwrap();
    assert_eq!(s.sensor.to_world, glam::Mat4::IDENTITY);
    assert_eq!((s.sensor.film.width, s.sensor.film.height), (768, 576));
    assert_eq!((s.sensor.sample_count, s.sensor.seed), (4, 0));
    assert!(s.warnings.iter().any(|w| w.contains("no sensor")));
}

/// Deterministic single-character mutations of a valid scene: loading may fail, never panic.
#[test]
fn mutated_scenes_never_panic() {
    let base = wrap(
        r#"<default name="r" value="0.001"/>
<bsdf type="diffuse" id="b"><rgb name="reflectance" value="0.2, 0.3, 0.4"/></bsdf>
<shape type="rectangle"><ref id="b"/><transform name="to_world"><scale value="4"/><rotate x="1" angle="-90"/></transform></shape>
<shape type="sphere"><point name="center" value="0 1 0"/><float name="radius" value="0.5"/></shape>
<shape type="cylinder"><point name="p0" x="-1" y="2"/><point name="p1" x="1" y="2"/><float name="radius" value="$r"/>
  <emitter type="area"><spectrum name="radiance" value="1000"/></emitter></shape>"#,
    );
    assert!(load_in("mutate-base", &base, &[]).is_ok());
    let d = dir("mutate");
    let p = d.join("scene.xml");
    let bytes = base.as_bytes();
    let replacements = [b'0', b'-', b'<', b'"', b'$', b'x', b' ', b'9', b'e', b'/'];
    let mut state: u64 = 0x853c49e6748fea9b;
    let mut failures = 0;
    for i in 0..400 {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let pos = (state >> 33) as usize % bytes.len();
        let mut m = bytes.to_vec();
        if i % 3 == 0 {
            m.remove(pos);
        } else {
            m[pos] = replacements[(state >> 20) as usize % replacements.len()];
        }
        std::fs::write(&p, &m).unwrap();
        failures += load_scene(&p, &[]).is_err() as usize;
    }
    // Sanity: the mutations do hit things the loader rejects.
    assert!(failures > 50, "{failures}");
}

#[test]
fn nesting_depth_is_limited() {
    let depth = 10_000;
    let xml = format!(
        "<scene version=\"3.0.0\">{}{}</scene>",
        "<transform name=\"t\">".repeat(depth),
        "</transform>".repeat(depth)
    );
    let e = load_err("deep", &xml);
    assert!(e.contains("nested more than 64 deep"), "{e}");
}

#[test]
fn cylinder_idiom_scale_rotate_translate() {
    // Mitsuba's default cylinder (p0 = 0, p1 = +z, radius 1) placed by scale(r, r, L), a
    // rotation and a translation: the axis from t to t + L·R·z, the radius r.
    let s = load(
        "idiom",
        r#"<shape type="cylinder">
  <transform name="to_world">
    <scale x="0.001" y="0.001" z="2"/>
    <rotate x="1" angle="90"/>
    <translate x="0.5" y="1" z="3"/>
  </transform>
  <emitter type="area"><rgb name="radiance" value="1000, 500, 250"/></emitter>
</shape>"#,
    );
    let l = &s.lights[0];
    assert!(close(l.begin, Vec3::new(0.5, 1.0, 3.0)), "{:?}", l.begin);
    assert!(close(l.end, Vec3::new(0.5, -1.0, 3.0)), "{:?}", l.end);
    assert!((l.radius - 0.001).abs() < 1e-9);
    let k = l.radiance_times_radius;
    assert!(
        (k[0] - 1.0).abs() < 1e-5 && (k[2] - 0.25).abs() < 1e-5,
        "{k:?}"
    );
    // The same with p0/p1/radius combined with a uniform scale.
    let s = load(
        "idiom2",
        r#"<shape type="cylinder">
  <point name="p0" value="0, 0, 1"/><point name="p1" value="1, 0, 1"/><float name="radius" value="0.01"/>
  <transform name="to_world"><scale value="2"/></transform>
  <emitter type="area"/>
</shape>"#,
    );
    let l = &s.lights[0];
    assert!(close(l.begin, Vec3::new(0.0, 0.0, 2.0)) && close(l.end, Vec3::new(2.0, 0.0, 2.0)));
    assert!((l.radius - 0.02).abs() < 1e-8);
}

#[test]
fn negative_radiance_warns() {
    let s = load(
        "negative",
        r#"<shape type="cylinder"><float name="radius" value="0.001"/><emitter type="area"><rgb name="radiance" value="-1, 2, 3"/></emitter></shape>"#,
    );
    assert!(
        s.warnings.iter().any(|w| w.contains("negative component")),
        "{:?}",
        s.warnings
    );
}

#[test]
fn film_output_options_follow_mitsuba() {
    let film = |opt: &str| {
        format!(
            "<scene version=\"3.0.0\">\n<integrator type=\"direct\"/>\n<sensor type=\"perspective\"><float name=\"fov\" value=\"40\"/><film type=\"hdrfilm\">{opt}<rfilter type=\"box\"/></film></sensor>\n</scene>\n"
        )
    };
    for ok in [
        r#"<string name="pixel_format" value="RGB"/>"#,
        r#"<string name="component_format" value="float16"/>"#,
        r#"<string name="file_format" value="openexr"/>"#,
    ] {
        load_in("film_ok", &film(ok), &[]).unwrap_or_else(|e| panic!("{ok}: {e}"));
    }
    for (bad, want) in [
        (
            r#"<string name="pixel_format" value="rgba"/>"#,
            "pixel_format 'rgba' is not supported",
        ),
        (
            r#"<string name="pixel_format" value="cmyk"/>"#,
            "must either be equal to",
        ),
        (
            r#"<string name="component_format" value="float64"/>"#,
            "must either be equal to",
        ),
        (
            r#"<string name="file_format" value="pfm"/>"#,
            "file_format 'pfm' is not supported",
        ),
    ] {
        let e = load_err("film_bad", &film(bad));
        assert!(e.contains(want), "{bad}: {e}");
    }
}

#[test]
fn elements_inside_properties_and_defaults_are_refused() {
    let scene = |body: &str| wrap(body); // body starts on line 4, column 1
    expect_error(
        "nest_string",
        &scene(
            r#"<shape type="sphere"><string name="x" value="y"><emitter type="area"/></string></shape>"#,
        ),
        "4:49",
        "<emitter> cannot be nested inside <string>",
    );
    expect_error(
        "nest_float",
        &scene(
            r#"<shape type="sphere"><float name="radius" value="1"><sensor type="perspective"/></float></shape>"#,
        ),
        "4:53",
        "<sensor> cannot be nested inside <float>",
    );
    expect_error(
        "nest_default",
        &scene(r#"<default name="a" value="1"><shape type="sphere"/></default>"#),
        "4:29",
        "<shape> cannot be nested inside <default>",
    );
    expect_error(
        "nest_ref",
        &scene(
            r#"<bsdf type="diffuse" id="b"/><shape type="sphere"><ref id="b"><point name="p" value="0"/></ref></shape>"#,
        ),
        "4:63",
        "<point> cannot be nested inside <ref>",
    );
    expect_error(
        "nest_op",
        &scene(
            r#"<shape type="sphere"><transform name="to_world"><translate x="1"><rgb name="c" value="1"/></translate></transform></shape>"#,
        ),
        "4:66",
        "<rgb> cannot be nested inside <translate>",
    );
}

#[test]
fn line_index_matches_roxmltree() {
    let text = "<a>\n  <b x=\"é\"/>\r\n\t<c>ü</c>\n\n<d/></a>";
    let doc = roxmltree::Document::parse(text).unwrap();
    let lines = tree::LineIndex::new(text);
    for node in doc.descendants() {
        let p = doc.text_pos_at(node.range().start);
        assert_eq!(lines.position(node.range().start), (p.row, p.col));
    }
    assert_eq!(lines.position(text.len()), {
        let p = doc.text_pos_at(text.len());
        (p.row, p.col)
    });
}

/// A scene of about `bytes` of spheres whose last shape is an error; its sphere count.
fn spheres_then_an_error(bytes: usize) -> (String, usize) {
    let mut body = String::new();
    let mut n = 0;
    while body.len() < bytes {
        body.push_str(&format!(
            "<shape type=\"sphere\">\n  <point name=\"center\" x=\"{}\" y=\"0\" z=\"5\"/>\n  \
             <float name=\"radius\" value=\"0.001\"/>\n  <bsdf type=\"diffuse\"><rgb \
             name=\"reflectance\" value=\"0.5 0.5 0.5\"/></bsdf>\n</shape>\n",
            n as f64 * 1e-3
        ));
        n += 1;
    }
    body.push_str("<shape type=\"sphere\"><float name=\"radius\" value=\"-1\"/></shape>");
    (wrap(&body), n)
}

/// Positions come from an index of line starts, so loading is linear in the file's size: an
/// 8 MB scene (≈ 40 000 spheres) loads in less than 24× the time of a 1 MB one (linear: 8×; a
/// rescan per node would be quadratic: 64×). Times are the minimum of three interleaved loads
/// each, a ratio within one run, so a loaded machine slows both alike.
#[test]
fn scene_load_time_is_linear_in_the_file_size() {
    let (small, n_small) = spheres_then_an_error(1 << 20);
    let (large, n_large) = spheres_then_an_error(8 << 20);
    let mut best = [f64::INFINITY; 2];
    for _ in 0..3 {
        for (k, (xml, n)) in [(&small, n_small), (&large, n_large)]
            .into_iter()
            .enumerate()
        {
            let t0 = std::time::Instant::now();
            let e = load_err("linear_load", xml);
            best[k] = best[k].min(t0.elapsed().as_secs_f64());
            // The last line's error is placed after 4 header lines and 5 lines per sphere.
            assert!(e.contains(&format!("scene.xml:{}:1: ", 4 + 5 * n)), "{e}");
        }
    }
    let ratio = best[1] / best[0];
    assert!(
        ratio < 24.0,
        "{n_large} spheres took {:.3} s, {n_small} took {:.3} s: {ratio:.1}×",
        best[1],
        best[0]
    );
}

/// A tutorial-like scene with six refused features: every refusal is reported at once, in file
/// order, each at its place and with what to write instead.
#[test]
fn every_refusal_is_reported_in_file_order() {
    let xml = r#"<scene version="3.0.0">
<integrator type="path"/>
<sensor type="perspective">
  <float name="focus_distance" value="3"/>
  <film type="hdrfilm"><rfilter type="gaussian"/></film>
</sensor>
<bsdf type="dielectric" id="glass"/>
<shape type="sphere"><ref id="glass"/></shape>
<shape type="rectangle"><bsdf type="conductor"/><emitter type="area"/></shape>
<emitter type="envmap"/>
</scene>
"#;
    let e = load_in("all_at_once", xml, &[]).unwrap_err();
    let all = e.all();
    let at: Vec<(u32, u32)> = all
        .iter()
        .map(|e| {
            let l = e.location.as_ref().unwrap();
            (l.line, l.column)
        })
        .collect();
    assert_eq!(
        at,
        [(2, 1), (5, 24), (7, 1), (9, 25), (9, 49), (10, 1)],
        "{e}"
    );
    let text = e.to_string();
    for want in [
        "write <integrator type=\"direct\"/>",
        "write <rfilter type=\"box\"/>",
        "closest: principled with metallic 0",
        "closest: roughconductor",
        "not on shape 'rectangle' (use a <shape type=\"cylinder\">",
        "unsupported emitter type 'envmap' (supported: area emitters on cylinders; use a <shape \
         type=\"cylinder\">",
        "6 problems in this scene",
    ] {
        assert!(text.contains(want), "missing '{want}' in:\n{text}");
    }
    // focus_distance is accepted: Mitsuba ignores it on a pinhole camera.
    assert!(!text.contains("focus_distance"), "{text}");
}

/// What Mitsuba 3.9.1 accepts and cannot change the image here loads (checked against
/// `mi.load_string` of the oracle's Mitsuba).
#[test]
fn properties_mitsuba_accepts_and_that_change_nothing_load() {
    let xml = r#"<scene version="3.0.0">
<integrator type="direct"><integer name="samples_per_pass" value="2"/><integer name="block_size" value="8"/><float name="timeout" value="100"/></integrator>
<sensor type="perspective"><float name="fov" value="40"/><float name="focus_distance" value="3"/><float name="shutter_open" value="0"/><float name="shutter_close" value="1"/>
<film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/><boolean name="sample_border" value="true"/><string name="component_format" value="float32"/><rfilter type="box"/></film></sensor>
<shape type="sphere"><float name="silhouette_sampling_weight" value="2"/></shape>
</scene>
"#;
    let s = load_in("mitsuba_ignores", xml, &[]).unwrap_or_else(|e| panic!("{e}"));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    // What Mitsuba refuses stays refused.
    let bad = xml.replace(
        r#"<float name="timeout" value="100"/>"#,
        r#"<integer name="max_depth" value="2"/>"#,
    );
    assert!(load_err("max_depth", &bad).contains("unsupported property 'max_depth'"));
    let bad = xml.replace(r#"value="1"/>"#, r#"value="-1"/>"#);
    assert!(load_err("shutter", &bad).contains("shutter_open must be less than"));
}

/// An object nothing references cannot matter: one linlight cannot parse is a warning, and the
/// scene loads; referenced, it is refused where it is used.
#[test]
fn unreferenced_objects_are_warnings() {
    let s = load(
        "unused",
        r#"<texture type="bitmap" id="tex"/><volume type="gridvolume" id="v"/>
<bsdf type="dielectric" id="glass"/><shape type="sphere"/>"#,
    );
    let w = s.warnings.join("\n");
    assert!(
        w.contains("texture 'bitmap' is not referenced by anything; ignored"),
        "{w}"
    );
    assert!(w.contains("volume 'gridvolume' is not referenced"), "{w}");
    assert!(
        w.contains(
            "bsdf 'dielectric' is not referenced by anything; ignored (linlight could not \
                    render it: unsupported bsdf type 'dielectric'"
        ),
        "{w}"
    );
    let e = load_err(
        "used",
        &wrap(
            r#"<bsdf type="dielectric" id="glass"/><shape type="sphere"><ref id="glass"/></shape>"#,
        ),
    );
    assert!(
        e.contains("scene.xml:4:1: unsupported bsdf type 'dielectric'"),
        "{e}"
    );
}

#[test]
fn missing_component_format_warns() {
    let without = SENSOR.replace(r#"<string name="component_format" value="float32"/>"#, "");
    let xml = format!(
        "<scene version=\"3.0.0\">\n<integrator type=\"direct\"/>\n{without}\n<shape type=\"sphere\"/>\n</scene>\n"
    );
    let s = load_in("no_component_format", &xml, &[]).unwrap();
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    assert!(
        s.warnings[0].contains("scene.xml:3:58: no <string name=\"component_format\""),
        "{:?}",
        s.warnings
    );
    let s = load("component_format", "<shape type=\"sphere\"/>");
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
}

/// A tube light's radius must be positive and finite: 0, negative, NaN and infinite radii are
/// refused at the shape's file:line:column.
#[test]
fn tube_radius_must_be_positive_and_finite() {
    for r in ["0", "-0.5", "nan", "inf"] {
        let xml = wrap(&format!(
            r#"<shape type="cylinder"><float name="radius" value="{r}"/><emitter type="area"/></shape>"#
        ));
        let e = load_err("radius", &xml);
        assert!(
            e.contains("scene.xml:4:") && e.contains("radius"),
            "radius {r}: got '{e}'"
        );
    }
}
