//! Measurements beside the bake, from the full-detail geometry and none of the form factors'
//! machinery: rows of F against hemisphere rays ([`row_check`], `radiosity check-rows`) and
//! object-to-object view factors ([`view_factors`], `radiosity view-factors`).

pub mod row_check;
pub mod view_factors;
