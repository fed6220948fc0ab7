//! Render surfaces carried by the simulation: detailed surfaces embedded in the bodies' tets
//! (see [`crate::mesh::embed`]), moved with them. Contact and every force act on the tets only;
//! a render surface is output.

use std::path::PathBuf;
use std::sync::Arc;

use super::Simulation;
use crate::io::render_obj::RenderSurface;
use crate::math::Vec3;
use crate::mesh::embed::Embedding;

/// A body's render surface and its binding to the body's rest tets.
#[derive(Clone, Debug)]
pub struct RenderBody {
    /// The body it is embedded in (index into the scene's bodies).
    pub body: usize,
    /// That body's name.
    pub name: String,
    /// The file it was read from.
    pub source: PathBuf,
    /// Faces, texture coordinates, groups and materials; rest positions placed with the body.
    pub surface: Arc<RenderSurface>,
    /// Each vertex's tet (the simulation's numbering) and barycentric coordinates.
    pub embedding: Arc<Embedding>,
}

impl Simulation {
    /// Carry these render surfaces (from the scene).
    pub fn with_render(mut self, render: Vec<RenderBody>) -> Self {
        self.render = render;
        self
    }

    /// The render surfaces, in body order.
    pub fn render_bodies(&self) -> &[RenderBody] {
        &self.render
    }

    /// The current positions of render surface `i` (of [`Simulation::render_bodies`]).
    pub fn render_positions(&self, i: usize) -> Vec<Vec3> {
        self.render[i]
            .embedding
            .positions(&self.body.mesh, &self.state.x)
    }
}
