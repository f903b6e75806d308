//! The pictures: properties that only a correct drawing has. The PNG is decoded here (with
//! the `png` crate, not the renderer's own buffers), and the pixels are looked up where the
//! camera puts points of the part.

use moldgate::math::DVec3;
use moldgate::mesh::{from_generated, LoadedMesh};
use moldgate::render::{png, render, RenderError, RenderOptions, ViewKind, GATE_COLOUR};
use moldgate::scene::{Field, Scene};
use moldgate::{locate, Analysis, LocateOptions};

fn sample(name: &str) -> (LoadedMesh, Analysis) {
    let part = from_generated(moldgate::samples::sample(name).expect("a sample"));
    let analysis = locate(&part, &LocateOptions::default()).expect("the analysis runs");
    (part, analysis)
}

/// Width, height and RGB pixels of a PNG.
fn decode(bytes: &[u8]) -> (u32, u32, Vec<[u8; 3]>) {
    let decoder = png::Decoder::new(std::io::Cursor::new(bytes));
    let mut reader = decoder.read_info().expect("a PNG header");
    let mut buf = vec![0; reader.output_buffer_size().expect("a size")];
    let info = reader.next_frame(&mut buf).expect("a PNG image");
    let channels = match info.color_type {
        png::ColorType::Rgb => 3,
        png::ColorType::Rgba => 4,
        other => panic!("unexpected colour type {other:?}"),
    };
    assert_eq!(info.bit_depth, png::BitDepth::Eight);
    let pixels = buf[..info.buffer_size()]
        .chunks_exact(channels)
        .map(|p| [p[0], p[1], p[2]])
        .collect();
    (info.width, info.height, pixels)
}

fn at(image: &(u32, u32, Vec<[u8; 3]>), x: f64, y: f64) -> [u8; 3] {
    let (w, h, px) = image;
    assert!(
        x >= 0.0 && y >= 0.0 && x < *w as f64 && y < *h as f64,
        "({x}, {y}) is outside"
    );
    px[y as usize * *w as usize + x as usize]
}

#[test]
fn the_gate_pixel_has_the_gate_colour_in_both_views_and_the_image_is_not_uniform() {
    for name in ["cover", "cap", "tray", "bracket", "plate"] {
        let (part, analysis) = sample(name);
        let scene = Scene::new(&part.mesh, &analysis, name);
        let picture = render(&scene, &RenderOptions::default()).unwrap();
        let bytes = picture.png().unwrap();
        let image = decode(&bytes);
        assert_eq!((image.0, image.1), (1600, 900));
        assert_eq!(picture.views.len(), 2);
        let gate = scene.gates[0].point;
        for view in &picture.views {
            let p = view.camera.to_pixel(gate);
            assert_eq!(at(&image, p.x, p.y), GATE_COLOUR, "{name} {:?}", view.kind);
            // The panel holds the gate.
            let r = view.panel;
            assert!(p.x > r.x as f64 && p.x < (r.x + r.w) as f64);
            assert!(p.y > r.y as f64 && p.y < (r.y + r.h) as f64);
        }
        let mut colours: Vec<[u8; 3]> = image.2.clone();
        colours.sort_unstable();
        colours.dedup();
        assert!(colours.len() > 200, "{name}: {} colours", colours.len());
        // The gate colour is used by the gate marks only: a small share of the picture.
        let gate_pixels = image.2.iter().filter(|&&c| c == GATE_COLOUR).count();
        assert!(
            gate_pixels > 10 && gate_pixels < 20_000,
            "{name}: {gate_pixels}"
        );
    }
}

#[test]
fn the_same_scene_gives_the_same_bytes() {
    let (part, analysis) = sample("tray");
    let scene = Scene::new(&part.mesh, &analysis, "tray");
    let a = png(&scene, &RenderOptions::default()).unwrap();
    let b = png(&scene, &RenderOptions::default()).unwrap();
    assert!(a == b, "two renders differ");
    // And a different scene gives different bytes.
    let mut moved = scene.clone();
    moved.title = "tray, again".into();
    assert!(png(&moved, &RenderOptions::default()).unwrap() != a);
}

#[test]
fn the_gate_is_drawn_where_the_scene_puts_it() {
    let (part, analysis) = sample("cover");
    let scene = Scene::new(&part.mesh, &analysis, "cover");
    let old = scene.gates[0].point;
    let mut moved = scene.clone();
    // Another point of the cover's top face, 15 mm along +X and 8 mm along -Y.
    moved.gates[0].point = old + DVec3::new(15.0, -8.0, 0.0);
    let picture = render(&moved, &RenderOptions::default()).unwrap();
    let image = decode(&picture.png().unwrap());
    let view = &picture.views[0];
    let new_px = view.camera.to_pixel(moved.gates[0].point);
    let old_px = view.camera.to_pixel(old);
    assert_eq!(at(&image, new_px.x, new_px.y), GATE_COLOUR);
    assert_ne!(at(&image, old_px.x, old_px.y), GATE_COLOUR);
    // Seen along +Z, +X is to the right and -Y is down.
    assert!(new_px.x > old_px.x + 10.0 && new_px.y > old_px.y + 5.0);
}

/// Median of each channel over a square of pixels around (x, y).
fn patch(image: &(u32, u32, Vec<[u8; 3]>), x: f64, y: f64) -> [u8; 3] {
    let mut channels = [vec![], vec![], vec![]];
    for dy in -3..=3 {
        for dx in -3..=3 {
            let c = at(image, x + dx as f64, y + dy as f64);
            for k in 0..3 {
                channels[k].push(c[k]);
            }
        }
    }
    channels.map(|mut v| {
        v.sort_unstable();
        v[v.len() / 2]
    })
}

#[test]
fn the_field_colours_the_part_where_the_values_are() {
    // The bracket: a base plate 5 mm high and a wall 50 mm high at low x. Coloured by
    // height (viridis), the wall's top is yellow and the plate's top is dark blue-purple.
    let (part, analysis) = sample("bracket");
    let scene = Scene::new(&part.mesh, &analysis, "bracket");
    let picture = render(&scene, &RenderOptions::default()).unwrap();
    let image = decode(&picture.png().unwrap());
    let b = moldgate::math::Aabb::of_points(&part.mesh.vertices);
    let top_of_wall = part
        .mesh
        .vertices
        .iter()
        .filter(|p| p.z > b.max.z - 1e-9)
        .fold(DVec3::ZERO, |s, p| s + *p)
        / part
            .mesh
            .vertices
            .iter()
            .filter(|p| p.z > b.max.z - 1e-9)
            .count() as f64;
    let plate = DVec3::new(b.max.x - 5.0, (b.min.y + b.max.y) / 2.0, 5.0);
    let view = &picture.views[0];
    assert_eq!(view.kind, ViewKind::AlongDemold);
    let w = view.camera.to_pixel(top_of_wall);
    let p = view.camera.to_pixel(plate);
    let wall = patch(&image, w.x, w.y);
    let base = patch(&image, p.x, p.y);
    assert!(
        wall[1] > 150 && wall[2] < 120,
        "wall top is yellow: {wall:?}"
    );
    assert!(
        base[1] < 90 && base[2] > 60,
        "plate top is dark blue-purple: {base:?}"
    );

    // A field of NaN (unknown everywhere) draws the part grey and still draws the gate.
    let unknown = scene.clone().with_field(Field {
        name: "fill order".into(),
        unit: "".into(),
        per_vertex: vec![f32::NAN; part.mesh.vertices.len()],
        cells: None,
        span: None,
    });
    let picture = render(&unknown, &RenderOptions::default()).unwrap();
    let image = decode(&picture.png().unwrap());
    let base = patch(&image, p.x, p.y);
    assert!(
        base[0].abs_diff(base[1]) < 12 && base[1].abs_diff(base[2]) < 12,
        "grey: {base:?}"
    );
    let g = picture.views[0].camera.to_pixel(scene.gates[0].point);
    assert_eq!(at(&image, g.x, g.y), GATE_COLOUR);
}

#[test]
fn bad_requests_are_errors() {
    let (part, analysis) = sample("plate");
    let scene = Scene::new(&part.mesh, &analysis, "plate");
    let small = RenderOptions {
        width: 100,
        height: 50,
    };
    assert_eq!(
        png(&scene, &small),
        Err(RenderError::Size {
            width: 100,
            height: 50
        })
    );
    let huge = RenderOptions {
        width: 100_000,
        height: 900,
    };
    assert!(matches!(png(&scene, &huge), Err(RenderError::Size { .. })));
    let short = scene.clone().with_field(Field {
        name: "thickness".into(),
        unit: "mm".into(),
        per_vertex: vec![1.0; 3],
        cells: None,
        span: None,
    });
    assert!(matches!(
        png(&short, &RenderOptions::default()),
        Err(RenderError::FieldLength { got: 3, .. })
    ));
    let empty_mesh = moldgate::Mesh {
        vertices: vec![],
        triangles: vec![],
    };
    let mut empty = scene.clone();
    empty.mesh = &empty_mesh;
    empty.field.per_vertex.clear();
    assert_eq!(
        png(&empty, &RenderOptions::default()),
        Err(RenderError::EmptyMesh)
    );
}

#[test]
fn other_sizes_keep_the_gate_in_place() {
    let (part, analysis) = sample("cap");
    let scene = Scene::new(&part.mesh, &analysis, "cap");
    for (width, height) in [(800, 450), (1920, 1080), (1200, 1200)] {
        let picture = render(&scene, &RenderOptions { width, height }).unwrap();
        let image = decode(&picture.png().unwrap());
        assert_eq!((image.0, image.1), (width, height));
        for view in &picture.views {
            let g = view.camera.to_pixel(scene.gates[0].point);
            assert_eq!(at(&image, g.x, g.y), GATE_COLOUR, "{width}x{height}");
        }
    }
}

/// The picture is coloured and deflated in bands on all threads: its bytes are the same on
/// one, two and three threads, with back faces skipped (the topology given) and not, and
/// at a height that is not a whole number of bands.
#[test]
fn the_bytes_do_not_depend_on_the_threads() {
    let (part, analysis) = sample("bracket");
    let plain = Scene::new(&part.mesh, &analysis, "bracket");
    let culled = plain.clone().with_topology(&part.topology);
    for (scene, options) in [
        (&plain, RenderOptions::default()),
        (
            &culled,
            RenderOptions {
                width: 1000,
                height: 777,
            },
        ),
    ] {
        let on = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| png(scene, &options).unwrap())
        };
        let one = on(1);
        assert!(one == on(2) && one == on(3), "{options:?}");
        assert_eq!(decode(&one).0, options.width);
    }
}
