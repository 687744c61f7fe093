//! The crate's wgpu toolkit: the device, buffer, texture and pipeline helpers every pass
//! builds with (the gather, the corner, probe, edit and level passes, the texture-unit
//! measurement). It knows no pass and no matrix: the passes import it, it imports none of them.
//!
//! - `bindings.rs`: binding types ([`UNIFORM`], [`READ`], [`WRITE`]), layout entries, buffer
//!   entries of a bind group;
//! - `resources.rs`: storage buffers and BC textures filled at creation;
//! - `passes.rs`: pipelines, dispatch grids within the device's limits, one-dispatch passes;
//! - `checks.rs`: the device's limits and the host's buffers checked before a pass is built,
//!   and the error scopes a build runs in.

mod bindings;
mod checks;
mod passes;
mod resources;

pub(crate) use bindings::{READ, UNIFORM, WRITE, buffer_ty, entire, layout_entry, sized};
pub(crate) use checks::{
    check_host_buffer, check_pass_limits, in_error_scopes, storage_binding_limit,
};
pub(crate) use passes::{pipeline, record_dispatch, workgroup_grid};
pub(crate) use resources::{storage, upload_texture};
