//! One light sample of a [`Shader`](super::Shader): a point of a lamp or window with its power
//! and main direction, shared by the scalar shading and the AVX sum.

use rapier3d::prelude::Vector;

#[derive(Debug, Clone, Copy)]
pub(super) struct LightSample {
    pub(super) pos: Vector,
    pub(super) power: f32,
    /// Main direction of emission (unit): lamps shine mostly down, windows into the room.
    pub(super) dir: Vector,
    /// Share of the power emitted regardless of direction (lamp housings scatter; a window
    /// lets light in only from outside).
    pub(super) isotropic: f32,
}
