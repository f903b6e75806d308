//! What a picture or a 3D file shows: the part, a colour field on it, the gates, the centre
//! of mass, the parting line and the qualifying region. Built once from an analysis and
//! handed to the writers (PNG, glTF), so they all show the same thing.

use std::sync::Arc;

use crate::display::{CellField, Display};
use crate::frame::Frame;
use crate::gate::{Analysis, ChosenGate};
use crate::math::DVec3;
use crate::mesh::{Mesh, Topology};

/// A scalar per vertex, shown as colours.
#[derive(Debug, Clone, PartialEq)]
pub struct Field {
    /// What the values are, for the colour bar ("height along D", "fill order").
    pub name: String,
    /// Their unit ("mm", "MPa", "" for none).
    pub unit: String,
    /// One value per mesh vertex; NaN where unknown (drawn grey).
    pub per_vertex: Vec<f32>,
    /// The field on the cells it was computed on, when it has them (the fill's fields):
    /// the writers then draw it on the surface refined to the cells ([`crate::display`]),
    /// and its colour bar spans the cells' values.
    pub cells: Option<Arc<CellField>>,
    /// The colour bar's span when it is not the values' own: a wall map's facets' range
    /// (the report's minimum and maximum), which the vertices' means of their facets
    /// narrow. Values outside it take its end colours.
    pub span: Option<[f32; 2]>,
}

impl Field {
    /// The smallest and largest finite value of the field: over its cells when it has them
    /// (the range the report quotes), its [`Field::span`] when given, over its vertices
    /// otherwise; `None` when none is finite.
    pub fn range(&self) -> Option<[f32; 2]> {
        match (&self.cells, self.span) {
            (Some(c), _) => c.range(),
            (None, Some(span)) => Some(span),
            (None, None) => crate::colormap::Range::of(&self.per_vertex).map(|r| [r.min, r.max]),
        }
    }

    /// The span of the colours, and, when it stops below the largest value, that value:
    /// a field on cells with a far tail of a few cells stops at their 99th percentile
    /// ([`CellField::colour_span`]); any other spans its [`Field::range`].
    pub fn colour_span(&self) -> Option<([f32; 2], Option<f32>)> {
        match &self.cells {
            Some(c) => c.colour_span(),
            None => self.range().map(|r| (r, None)),
        }
    }
}

/// A scalar per qualifying point (the gate-suitability map), shown as colours over the
/// qualifying region in place of the part's field (the part is then grey).
#[derive(Debug, Clone, PartialEq)]
pub struct NodeField {
    /// What the values are, for the colour bar.
    pub name: String,
    /// Their unit.
    pub unit: String,
    /// One value per point of [`Scene::qualifying`]; NaN where unknown.
    pub per_node: Vec<f32>,
}

/// A gate marker: a disc of radius `radius_mm` on the surface at `point`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Marker {
    /// Position on the surface, mm.
    pub point: DVec3,
    /// Outward surface normal there (unit; zero when unknown).
    pub normal: DVec3,
    /// Disc radius, mm (the gate radius R_gate).
    pub radius_mm: f64,
    /// The body whose own gate this is, on a part of several bodies where the answer's
    /// gates do not reach that body (see [`crate::flow::BodyGate`]); `None` for the answer's
    /// gates.
    pub body: Option<u32>,
}

/// A gate the designer placed (`gate_at`): its disc, and whether it passes the paper's
/// rules.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlacedMarker {
    /// The disc on the surface.
    pub marker: Marker,
    /// Whether it qualifies.
    pub qualifies: bool,
}

/// Everything a view of one analysis shows.
#[derive(Debug, Clone)]
pub struct Scene<'a> {
    /// The part, mm.
    pub mesh: &'a Mesh,
    /// The part's topology, when known ([`Scene::with_topology`]): on a closed, consistently
    /// oriented mesh the picture skips the facets turned away from the viewer, which the
    /// part's own front faces hide.
    pub topology: Option<&'a Topology>,
    /// Demolding frame (d, u, w).
    pub frame: Frame,
    /// Colour field on the part.
    pub field: Field,
    /// The surface the field is drawn on when it lives on cells: the part refined to the
    /// cells with the field at its vertices (set by [`Scene::with_field`]); `None` draws
    /// `field.per_vertex` on the part's own triangles.
    pub display: Option<Arc<Display>>,
    /// The chosen gate and any further gates (several-gate runs), first is the main one.
    pub gates: Vec<Marker>,
    /// The gates the designer placed, in the order given (drawn apart from the answer's).
    pub placed: Vec<PlacedMarker>,
    /// The centre of mass the gate was placed by.
    pub centre: DVec3,
    /// The parting line as polylines of 3D points.
    pub parting: Vec<Vec<DVec3>>,
    /// Surface points of the nodes that qualify as gate positions.
    pub qualifying: Vec<DVec3>,
    /// A value per qualifying point shown over the qualifying region (the gate-suitability
    /// map), when set with [`Scene::with_node_field`].
    pub node_field: Option<NodeField>,
    /// Distance between neighbouring grid nodes, mm (each qualifying point stands for a
    /// square of this side).
    pub grid_spacing_mm: f64,
    /// The designer's keep-out regions, drawn dashed.
    pub keep_out: Vec<crate::keepout::Region>,
    /// First title line (file or sample name).
    pub title: String,
    /// Second title line (material, gate coordinates).
    pub subtitle: String,
}

impl<'a> Scene<'a> {
    /// The scene of an analysis, coloured by height along the demolding direction (the
    /// field to use until a better one is set with [`Scene::with_field`]).
    pub fn new(mesh: &'a Mesh, analysis: &Analysis, title: impl Into<String>) -> Scene<'a> {
        let frame = analysis.frame;
        let per_vertex = mesh
            .vertices
            .iter()
            .map(|&p| frame.height(p) as f32)
            .collect();
        let r = analysis.options.gate_radius_mm;
        let gates = analysis
            .gate()
            .ok()
            .map(|g| Marker {
                point: g.point(),
                normal: match g {
                    ChosenGate::Paper(g) => g.normal,
                    ChosenGate::Aesthetic(_) => DVec3::ZERO,
                },
                radius_mm: r,
                body: None,
            })
            .into_iter()
            .collect();
        let subtitle = match analysis.gate() {
            Ok(g) => {
                let p = g.point();
                format!(
                    "gate ({:.3}, {:.3}, {:.3}) mm, R = {:.3} mm",
                    p.x, p.y, p.z, r
                )
            }
            Err(_) => "no gate".to_string(),
        };
        Scene {
            mesh,
            topology: None,
            frame,
            field: Field {
                name: "height along D".into(),
                unit: "mm".into(),
                per_vertex,
                cells: None,
                span: None,
            },
            display: None,
            gates,
            placed: Vec::new(),
            centre: analysis.centre,
            parting: analysis.parting.polylines(mesh),
            qualifying: analysis.qualifying_points.clone(),
            node_field: None,
            grid_spacing_mm: analysis.grid.spacing,
            keep_out: analysis.options.keep_out.clone(),
            title: title.into(),
            subtitle,
        }
    }

    /// The same scene with the part's topology (the one of [`crate::mesh::LoadedMesh`],
    /// built for `mesh`), which lets the picture skip back faces when the mesh is closed and
    /// consistently oriented.
    pub fn with_topology(mut self, topology: &'a Topology) -> Scene<'a> {
        self.topology = Some(topology);
        self
    }

    /// The same scene with the qualifying region coloured by `field` (one value per
    /// qualifying point) and the rest of the part grey; the colour bar is `field`'s.
    pub fn with_node_field(mut self, field: NodeField) -> Scene<'a> {
        self.field = Field {
            name: field.name.clone(),
            unit: field.unit.clone(),
            per_vertex: vec![f32::NAN; self.mesh.vertices.len()],
            cells: None,
            span: None,
        };
        self.display = None;
        self.node_field = Some(field);
        self
    }

    /// The same scene coloured by another field; a field on cells is drawn on the part
    /// refined to them ([`crate::display::refine`]).
    pub fn with_field(self, field: Field) -> Scene<'a> {
        let display = field
            .cells
            .as_ref()
            .and_then(|c| crate::display::refine(self.mesh, c))
            .map(Arc::new);
        self.with_refined_field(field, display)
    }

    /// The same scene coloured by `field`, drawn on `display`: what [`Scene::with_field`]
    /// refines, made before (by [`crate::display::refine`] for this scene's mesh and
    /// `field`'s cells) and shared between scenes.
    pub fn with_refined_field(mut self, field: Field, display: Option<Arc<Display>>) -> Scene<'a> {
        self.display = display;
        self.field = field;
        self
    }

    /// The triangles drawn and the field's value at each of their vertices: the refined
    /// surface when there is one, else the part and `field.per_vertex`.
    pub fn surface(&self) -> (&Mesh, &[f32]) {
        match &self.display {
            Some(d) => (&d.mesh, &d.values),
            None => (self.mesh, &self.field.per_vertex),
        }
    }
}
