//! Property test of the whole analysis: random small closed parts (unions of boxes, prisms
//! turned to any angle), random demolding directions and options never panic, and every
//! number of the report is finite.
//!
//! serde_json writes a NaN or an infinity as `null`, so walking the JSON value cannot see
//! them: the report is walked by a serializer of its own that records the path of every
//! float that is not finite (and of every float the JSON holds, to be sure the walk reached
//! them).

use moldgate::flow::{self, FillOptions, FlowOptions, Objective, Walls};
use moldgate::gate::quadrature::Spacing;
use moldgate::gate::{FlatRule, Nearest, ThicknessRule};
use moldgate::math::DVec3;
use moldgate::mesh::from_generated;
use moldgate::raycast::Bvh;
use moldgate::report::{Input, RadiusSource, Report};
use moldgate::samples::BoxUnion;
use moldgate::{locate, Direction, GateMode, LocateOptions, Material, Mesh};
use proptest::prelude::*;

/// A union of one to three boxes, maybe less a box (several bodies are fine).
fn boxes() -> impl Strategy<Value = Mesh> {
    let corner = || (0.0..40.0f64, 0.0..40.0f64, 0.0..20.0f64);
    let size = || (0.5..30.0f64, 0.5..30.0f64, 0.5..15.0f64);
    (
        prop::collection::vec((corner(), size()), 1..4),
        prop::option::of((corner(), size())),
    )
        .prop_map(|(adds, sub)| {
            let mut b = BoxUnion::default();
            let span = |((x, y, z), (w, d, h)): ((f64, f64, f64), (f64, f64, f64))| {
                ([x, y, z], [x + w, y + d, z + h])
            };
            for a in adds {
                let (lo, hi) = span(a);
                b.add(lo, hi);
            }
            if let Some(s) = sub {
                let (lo, hi) = span(s);
                b.subtract(lo, hi);
            }
            b.mesh()
        })
}

/// A prism on a regular polygon of 3 to 12 sides, turned by two random angles and moved.
fn prism() -> impl Strategy<Value = Mesh> {
    (
        3usize..13,
        0.5..40.0f64,
        0.2..30.0f64,
        0.0..std::f64::consts::TAU,
        0.0..std::f64::consts::PI,
        (-100.0..100.0f64, -100.0..100.0f64, -100.0..100.0f64),
    )
        .prop_map(|(n, radius, height, yaw, pitch, (ox, oy, oz))| {
            let turn = |p: DVec3| {
                let (s, c) = yaw.sin_cos();
                let p = DVec3::new(c * p.x - s * p.y, s * p.x + c * p.y, p.z);
                let (s, c) = pitch.sin_cos();
                DVec3::new(p.x, c * p.y - s * p.z, s * p.y + c * p.z) + DVec3::new(ox, oy, oz)
            };
            let mut vertices = vec![turn(DVec3::ZERO), turn(DVec3::new(0.0, 0.0, height))];
            for z in [0.0, height] {
                for k in 0..n {
                    let a = std::f64::consts::TAU * k as f64 / n as f64;
                    vertices.push(turn(DVec3::new(radius * a.cos(), radius * a.sin(), z)));
                }
            }
            let n32 = n as u32;
            let bottom = |k: u32| 2 + k % n32;
            let top = |k: u32| 2 + n32 + k % n32;
            let mut triangles = Vec::new();
            for k in 0..n32 {
                triangles.push([0, bottom(k + 1), bottom(k)]);
                triangles.push([1, top(k), top(k + 1)]);
                triangles.push([bottom(k), bottom(k + 1), top(k + 1)]);
                triangles.push([bottom(k), top(k + 1), top(k)]);
            }
            Mesh {
                vertices,
                triangles,
            }
        })
}

fn direction() -> impl Strategy<Value = DVec3> {
    prop_oneof![
        prop::sample::select(vec![
            DVec3::X,
            DVec3::NEG_X,
            DVec3::Y,
            DVec3::NEG_Y,
            DVec3::Z,
            DVec3::NEG_Z
        ]),
        (-1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64)
            .prop_filter("not too short", |(x, y, z)| x * x + y * y + z * z > 1e-4)
            .prop_map(|(x, y, z)| DVec3::new(x, y, z)),
    ]
}

#[derive(Debug, Clone)]
struct Choices {
    radius_mm: f64,
    spacing_mm: Option<f64>,
    offset: f64,
    circle_points: usize,
    nearest_2d: bool,
    ignore_thickness: bool,
    require_flat: bool,
    aesthetic: bool,
    balanced: bool,
    resistance: bool,
    gates: usize,
    measure_walls: bool,
    cell_mm: Option<f64>,
}

fn choices() -> impl Strategy<Value = Choices> {
    (
        (
            0.2..6.0f64,
            prop::option::of(0.3..5.0f64),
            0.0..1.0f64,
            1usize..24,
        ),
        prop::array::uniform5(any::<bool>()),
        (1usize..4, any::<bool>(), prop::option::of(0.2..4.0f64)),
    )
        .prop_map(
            |((radius_mm, spacing_mm, offset, circle_points), b, (gates, m, cell_mm))| Choices {
                radius_mm,
                spacing_mm,
                offset,
                circle_points,
                nearest_2d: b[0],
                ignore_thickness: b[1],
                require_flat: b[2],
                aesthetic: b[3],
                balanced: b[4],
                resistance: gates == 3,
                gates,
                measure_walls: m,
                cell_mm,
            },
        )
}

/// Loads, locates, fills (when there is a gate) and reports; the report's non-finite floats.
fn analyse(mesh: Mesh, d: DVec3, c: &Choices) -> Result<(Vec<String>, usize), TestCaseError> {
    // A box subtracted over the whole union leaves nothing to load (a generated mesh
    // must have area): nothing to analyse.
    if mesh.triangles.is_empty() {
        return Ok((Vec::new(), 0));
    }
    let part = from_generated(mesh);
    let material = Material::builtin("ABS").unwrap();
    let options = LocateOptions {
        direction: Direction::new(d).map_err(|e| TestCaseError::fail(e.to_string()))?,
        gate_radius_mm: c.radius_mm,
        spacing: c.spacing_mm.map_or(Spacing::Auto, Spacing::Mm),
        grid_offset: c.offset,
        circle_points: c.circle_points,
        nearest: if c.nearest_2d {
            Nearest::Plane2d
        } else {
            Nearest::Surface3d
        },
        thickness_rule: if c.ignore_thickness {
            ThicknessRule::Ignore
        } else {
            ThicknessRule::Require
        },
        flat_rule: if c.require_flat {
            FlatRule::Require
        } else {
            FlatRule::Report
        },
        mode: if c.aesthetic {
            GateMode::Aesthetic
        } else {
            GateMode::Paper
        },
        max_nodes: 20_000,
        ..LocateOptions::default()
    };
    // A grid over the limit is a typed error, as the options promise.
    let Ok(analysis) = locate(&part, &options) else {
        return Ok((Vec::new(), 0));
    };
    let mut report = Report::new(
        Input {
            path: None,
            sample: Some("property".into()),
            bytes: 0,
        },
        &part.stats,
        &part.warnings,
        &material,
        RadiusSource::Forced,
        &analysis,
        0.0,
    );
    if analysis.gate().is_ok() {
        let fill = FillOptions {
            flow: FlowOptions {
                cell_mm: c.cell_mm,
                max_cells: 30_000.0,
                ..FlowOptions::default()
            },
            strategy: if c.balanced {
                flow::Strategy::Balanced
            } else {
                flow::Strategy::Paper
            },
            objective: if c.resistance {
                Objective::Resistance
            } else {
                Objective::Length
            },
            gates: c.gates,
            colour_by: Default::default(),
            placed: Vec::new(),
            // The suitability map rides on the balanced runs: its floats are checked too.
            suitability: c.balanced,
        };
        let bvh = Bvh::new(&part.mesh);
        let walls = if c.measure_walls {
            Walls::Measure(&bvh)
        } else {
            Walls::Estimate
        };
        if let Ok(f) = flow::analyse(&part.mesh, &analysis, &material, walls, &fill) {
            report = report.with_fill(f, analysis.centre);
        }
    }
    let mut walk = finite::Walk::default();
    serde::Serialize::serialize(&report, &mut walk).map_err(|e| TestCaseError::fail(e.0))?;
    Ok((walk.not_finite, walk.floats))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 32, ..ProptestConfig::default() })]

    #[test]
    fn random_boxes_never_panic_and_report_finite_numbers(
        mesh in boxes(), d in direction(), c in choices()
    ) {
        let (bad, floats) = analyse(mesh, d, &c)?;
        prop_assert!(bad.is_empty(), "not finite: {bad:?}");
        prop_assert!(floats == 0 || floats > 20, "the walk saw {floats} floats");
    }

    #[test]
    fn random_prisms_never_panic_and_report_finite_numbers(
        mesh in prism(), d in direction(), c in choices()
    ) {
        let (bad, floats) = analyse(mesh, d, &c)?;
        prop_assert!(bad.is_empty(), "not finite: {bad:?}");
        prop_assert!(floats == 0 || floats > 20, "the walk saw {floats} floats");
    }
}

#[test]
fn the_walk_finds_a_nan_that_json_would_write_as_null() {
    #[derive(serde::Serialize)]
    struct Inner {
        ok: f64,
        bad: Option<f32>,
    }
    #[derive(serde::Serialize)]
    struct Outer {
        list: Vec<Inner>,
        top: [f64; 2],
    }
    let value = Outer {
        list: vec![
            Inner { ok: 1.0, bad: None },
            Inner {
                ok: 2.0,
                bad: Some(f32::NAN),
            },
        ],
        top: [0.0, f64::INFINITY],
    };
    assert_eq!(
        serde_json::to_value(&value).unwrap()["list"][1]["bad"],
        serde_json::Value::Null
    );
    let mut walk = finite::Walk::default();
    serde::Serialize::serialize(&value, &mut walk).unwrap();
    assert_eq!(walk.not_finite, ["list.1.bad = NaN", "top.1 = inf"]);
    assert_eq!(walk.floats, 5);
}

/// A serde serializer that writes nothing: it walks a value and keeps the path of every
/// float that is not finite.
mod finite {
    use serde::ser::{self, Serialize};

    #[derive(Debug)]
    pub struct Error(pub String);

    impl std::fmt::Display for Error {
        fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            f.write_str(&self.0)
        }
    }
    impl std::error::Error for Error {}
    impl ser::Error for Error {
        fn custom<T: std::fmt::Display>(msg: T) -> Self {
            Error(msg.to_string())
        }
    }

    #[derive(Default)]
    pub struct Walk {
        path: Vec<String>,
        pub not_finite: Vec<String>,
        pub floats: usize,
    }

    impl Walk {
        fn float(&mut self, v: f64) {
            self.floats += 1;
            if !v.is_finite() {
                self.not_finite
                    .push(format!("{} = {v}", self.path.join(".")));
            }
        }
        fn nested<T: Serialize + ?Sized>(&mut self, key: String, v: &T) -> Result<(), Error> {
            self.path.push(key);
            let r = v.serialize(&mut *self);
            self.path.pop();
            r
        }
    }

    type R = Result<(), Error>;

    impl<'a> ser::Serializer for &'a mut Walk {
        type Ok = ();
        type Error = Error;
        type SerializeSeq = Seq<'a>;
        type SerializeTuple = Seq<'a>;
        type SerializeTupleStruct = Seq<'a>;
        type SerializeTupleVariant = Seq<'a>;
        type SerializeMap = Seq<'a>;
        type SerializeStruct = Seq<'a>;
        type SerializeStructVariant = Seq<'a>;

        fn serialize_bool(self, _: bool) -> R {
            Ok(())
        }
        fn serialize_i8(self, _: i8) -> R {
            Ok(())
        }
        fn serialize_i16(self, _: i16) -> R {
            Ok(())
        }
        fn serialize_i32(self, _: i32) -> R {
            Ok(())
        }
        fn serialize_i64(self, _: i64) -> R {
            Ok(())
        }
        fn serialize_u8(self, _: u8) -> R {
            Ok(())
        }
        fn serialize_u16(self, _: u16) -> R {
            Ok(())
        }
        fn serialize_u32(self, _: u32) -> R {
            Ok(())
        }
        fn serialize_u64(self, _: u64) -> R {
            Ok(())
        }
        fn serialize_f32(self, v: f32) -> R {
            self.float(f64::from(v));
            Ok(())
        }
        fn serialize_f64(self, v: f64) -> R {
            self.float(v);
            Ok(())
        }
        fn serialize_char(self, _: char) -> R {
            Ok(())
        }
        fn serialize_str(self, _: &str) -> R {
            Ok(())
        }
        fn serialize_bytes(self, _: &[u8]) -> R {
            Ok(())
        }
        fn serialize_none(self) -> R {
            Ok(())
        }
        fn serialize_some<T: Serialize + ?Sized>(self, v: &T) -> R {
            v.serialize(self)
        }
        fn serialize_unit(self) -> R {
            Ok(())
        }
        fn serialize_unit_struct(self, _: &'static str) -> R {
            Ok(())
        }
        fn serialize_unit_variant(self, _: &'static str, _: u32, _: &'static str) -> R {
            Ok(())
        }
        fn serialize_newtype_struct<T: Serialize + ?Sized>(self, _: &'static str, v: &T) -> R {
            v.serialize(self)
        }
        fn serialize_newtype_variant<T: Serialize + ?Sized>(
            self,
            _: &'static str,
            _: u32,
            variant: &'static str,
            v: &T,
        ) -> R {
            self.nested(variant.into(), v)
        }
        fn serialize_seq(self, _: Option<usize>) -> Result<Seq<'a>, Error> {
            Ok(Seq {
                walk: self,
                index: 0,
            })
        }
        fn serialize_tuple(self, _: usize) -> Result<Seq<'a>, Error> {
            Ok(Seq {
                walk: self,
                index: 0,
            })
        }
        fn serialize_tuple_struct(self, _: &'static str, _: usize) -> Result<Seq<'a>, Error> {
            Ok(Seq {
                walk: self,
                index: 0,
            })
        }
        fn serialize_tuple_variant(
            self,
            _: &'static str,
            _: u32,
            _: &'static str,
            _: usize,
        ) -> Result<Seq<'a>, Error> {
            Ok(Seq {
                walk: self,
                index: 0,
            })
        }
        fn serialize_map(self, _: Option<usize>) -> Result<Seq<'a>, Error> {
            Ok(Seq {
                walk: self,
                index: 0,
            })
        }
        fn serialize_struct(self, _: &'static str, _: usize) -> Result<Seq<'a>, Error> {
            Ok(Seq {
                walk: self,
                index: 0,
            })
        }
        fn serialize_struct_variant(
            self,
            _: &'static str,
            _: u32,
            _: &'static str,
            _: usize,
        ) -> Result<Seq<'a>, Error> {
            Ok(Seq {
                walk: self,
                index: 0,
            })
        }
    }

    pub struct Seq<'a> {
        walk: &'a mut Walk,
        index: usize,
    }

    impl Seq<'_> {
        fn element<T: Serialize + ?Sized>(&mut self, v: &T) -> R {
            let key = self.index.to_string();
            self.index += 1;
            self.walk.nested(key, v)
        }
    }

    impl ser::SerializeSeq for Seq<'_> {
        type Ok = ();
        type Error = Error;
        fn serialize_element<T: Serialize + ?Sized>(&mut self, v: &T) -> R {
            self.element(v)
        }
        fn end(self) -> R {
            Ok(())
        }
    }
    impl ser::SerializeTuple for Seq<'_> {
        type Ok = ();
        type Error = Error;
        fn serialize_element<T: Serialize + ?Sized>(&mut self, v: &T) -> R {
            self.element(v)
        }
        fn end(self) -> R {
            Ok(())
        }
    }
    impl ser::SerializeTupleStruct for Seq<'_> {
        type Ok = ();
        type Error = Error;
        fn serialize_field<T: Serialize + ?Sized>(&mut self, v: &T) -> R {
            self.element(v)
        }
        fn end(self) -> R {
            Ok(())
        }
    }
    impl ser::SerializeTupleVariant for Seq<'_> {
        type Ok = ();
        type Error = Error;
        fn serialize_field<T: Serialize + ?Sized>(&mut self, v: &T) -> R {
            self.element(v)
        }
        fn end(self) -> R {
            Ok(())
        }
    }
    impl ser::SerializeMap for Seq<'_> {
        type Ok = ();
        type Error = Error;
        fn serialize_key<T: Serialize + ?Sized>(&mut self, _: &T) -> R {
            Ok(())
        }
        fn serialize_value<T: Serialize + ?Sized>(&mut self, v: &T) -> R {
            self.element(v)
        }
        fn end(self) -> R {
            Ok(())
        }
    }
    impl ser::SerializeStruct for Seq<'_> {
        type Ok = ();
        type Error = Error;
        fn serialize_field<T: Serialize + ?Sized>(&mut self, key: &'static str, v: &T) -> R {
            self.walk.nested(key.into(), v)
        }
        fn end(self) -> R {
            Ok(())
        }
    }
    impl ser::SerializeStructVariant for Seq<'_> {
        type Ok = ();
        type Error = Error;
        fn serialize_field<T: Serialize + ?Sized>(&mut self, key: &'static str, v: &T) -> R {
            self.walk.nested(key.into(), v)
        }
        fn end(self) -> R {
            Ok(())
        }
    }
}
