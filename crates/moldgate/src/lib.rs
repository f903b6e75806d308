//! # moldgate
//!
//! Finds where to put the injection gate of a plastic part from nothing but its triangle
//! mesh, following Mercado-Colmenero, Torres-Alba and Martin-Doñate, *Methodology for
//! intelligent injection point location based on geometric algorithms and discrete
//! topologies for virtual digital twin environments* (equation numbers in the code refer to
//! that paper):
//!
//! 1. read the mesh ([`mesh`]);
//! 2. centre of mass by superposition, Eq. 3-5 ([`centre`]);
//! 3. gate radius from the material, Eq. 7-8 ([`material`]);
//! 4. a grid of nodes over the part, seen along the demolding direction ([`gate::quadrature`]);
//! 5. each node and a circle of radius R around it projected onto the part
//!    ([`gate::projection`]); a node qualifies when the whole circle lands on the part and the
//!    wall is thicker than R;
//! 6. the gate is the qualifying node nearest the centre of mass ([`gate::locate`]), or, for
//!    aesthetic parts, the point of the parting line nearest it ([`parting`]).
//!
//! The analysis does no I/O; reading files is the caller's business.
//!
//! ```
//! use moldgate::{locate, LocateOptions, Material};
//!
//! let part = moldgate::mesh::from_generated(moldgate::samples::sample("plate").unwrap());
//! let options = LocateOptions {
//!     gate_radius_mm: Material::builtin("ABS").unwrap().gate_radius_mm(),
//!     ..LocateOptions::default()
//! };
//! let analysis = locate(&part, &options).unwrap();
//! let gate = analysis.gate().unwrap();
//! println!("gate at {:?}", gate.point());
//! ```
#![deny(missing_docs)]
#![forbid(unsafe_code)]

pub mod batch_row;
pub mod cancel;
pub mod centre;
pub mod clock;
pub mod colormap;
pub mod display;
pub mod error;
pub mod files;
pub mod flow;
pub mod frame;
pub mod gate;
pub mod gltf;
pub mod html;
pub mod keepout;
pub mod material;
pub mod math;
pub mod mesh;
pub mod parting;
pub mod raycast;
pub mod render;
pub mod report;
pub mod samples;
pub mod scene;
pub mod study;
pub mod thickness;
pub mod undercut;

pub use centre::{CentreKind, Centres};
pub use error::{LoadError, LocateError, OptionsError};
pub use frame::{Direction, Frame};
pub use gate::{locate, Analysis, GateMode, LocateOptions};
pub use material::Material;
pub use mesh::{LoadedMesh, Mesh};
pub use study::{study, study_with, Study, StudyError, StudyOptions};
