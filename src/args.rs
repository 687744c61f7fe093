//! Flags shared by several subcommands.

use clap::Args;

/// The flags of the commands that bake an embedded scene and show it (`demo`, `sunset`).
#[derive(Args, Clone, Debug)]
pub(crate) struct ShowArgs {
    /// Directory for the files it writes.
    #[arg(long, default_value = ".")]
    pub(crate) out: std::path::PathBuf,
    /// Gather backend: auto, cpu, gpu or reference (default: $RADIOSITY_BACKEND, else auto).
    #[arg(long)]
    pub(crate) backend: Option<String>,
    /// Target patch count of the bake.
    #[arg(long, value_name = "N", default_value_t = 2048, allow_negative_numbers = true, value_parser = patch_count)]
    pub(crate) patches: usize,
}

/// How to bake (`bake`, and `solve` on an OBJ).
#[derive(Args, Clone, Debug)]
pub(crate) struct BakeArgs {
    /// Target patch count (hit within ±10%; refused at once above what this machine's memory
    /// holds).
    #[arg(long, value_name = "N", allow_negative_numbers = true, value_parser = patch_count)]
    pub(crate) patches: Option<usize>,
    /// Voxel cell size in scene units (instead of --patches).
    #[arg(long, allow_negative_numbers = true)]
    pub(crate) voxel: Option<f64>,
    /// Bounces: a number K ≥ 1, `inf`, or `auto` (as few as the energy needs).
    #[arg(long, default_value = "auto", allow_negative_numbers = true)]
    pub(crate) bounces: String,
    /// Storage format: auto, bc1, bc4, u8, f16, f32.
    #[arg(long, default_value = "auto")]
    pub(crate) format: String,
    /// Patch order: none, random, paper, spatial, best.
    #[arg(long, default_value = "best")]
    pub(crate) order: String,
    /// Fraction of the largest entries kept exactly in the sparse list (log formats).
    #[arg(long, allow_negative_numbers = true)]
    pub(crate) sparse: Option<f32>,
    /// Share of the 4×4 blocks given a block correction, sixteen 4-bit residuals per channel
    /// (BC1 and BC4; default: three quarters of the sparse budget, 2.5% of the blocks for BC1)
    #[arg(long, allow_negative_numbers = true)]
    pub(crate) corrections: Option<f32>,
    /// Largest tile side in patches (a multiple of 4); each tile has its own log scale per
    /// channel
    #[arg(long, allow_negative_numbers = true)]
    pub(crate) tile: Option<u32>,
    /// Form factors: `draft` (centroid rule, coarse leaves: previews; on scenes of many small
    /// triangles the quicker knob than fewer patches: a third less time on the conference room),
    /// `default` (degree-2 rule), `fine` (finer leaves next to edges, four shadow rays per
    /// leaf: final bakes)
    #[arg(
        long = "form-factors",
        value_name = "QUALITY",
        default_value = "default"
    )]
    pub(crate) form_factors: String,
    /// Lower reflectances (MTL Kd, glTF baseColorFactor, times the texture) at or above R, in
    /// (0, 1), to R, with one warning (default: those at or above 1, as many exporters write
    /// for white, to 0.95)
    #[arg(long, value_name = "R", allow_negative_numbers = true)]
    pub(crate) max_reflectance: Option<f64>,
    /// Direct-light points a patch has at least in the file's mesh (1 to 64; default 4): where
    /// the lights file's shadows are sampled on a patch of few pieces. More: shadow edges
    /// across large patches averaged more finely, 28 bytes of file and a shadow ray a frame
    /// each (docs/decisions/direct-light-points.md)
    #[arg(
        long = "direct-points",
        value_name = "N",
        allow_negative_numbers = true
    )]
    pub(crate) direct_points: Option<u32>,
    /// Direct-light points of a patch a shadow may cross (1 to 64; default 32): a patch whose
    /// points see out differently in some of 16 directions gets this many instead of
    /// --direct-points (docs/decisions/shadow-points.md)
    #[arg(
        long = "shadow-points",
        value_name = "N",
        allow_negative_numbers = true
    )]
    pub(crate) shadow_points: Option<u32>,
    /// Measure each patch's sky visibility so that a sky or environment light can light the
    /// file: on, off
    #[arg(long, value_name = "on|off", default_value = "on")]
    pub(crate) sky: String,
    /// Cut the patches into systems, each with its own transfer, light passing between them
    /// at run time: off (one matrix), auto (systems of at most 2048 patches above 8192
    /// patches), or a count (docs/decisions/systems.md)
    #[arg(long, value_name = "off|auto|N", default_value = "auto")]
    pub(crate) systems: String,
    /// The memory the bake may take at its peak, in GB (default: this machine's physical
    /// memory); a --patches target whose estimated peak exceeds it is refused at once
    #[arg(
        long = "memory-budget",
        value_name = "GB",
        allow_negative_numbers = true
    )]
    pub(crate) memory_budget: Option<f64>,
    /// The flags above given on the command line (`--patches`, …), filled in by `main`: a
    /// `.rad` input refuses them, since they do not apply to a file already baked.
    #[arg(skip)]
    pub(crate) given: Vec<String>,
}

impl BakeArgs {
    /// The command line's defaults with `--patches patches`: the bake of `demo` and `sunset`.
    pub(crate) fn with_patches(patches: usize) -> Self {
        BakeArgs {
            patches: Some(patches),
            voxel: None,
            bounces: "auto".into(),
            format: "auto".into(),
            order: "best".into(),
            sparse: None,
            corrections: None,
            tile: None,
            form_factors: "default".into(),
            max_reflectance: None,
            direct_points: None,
            shadow_points: None,
            sky: "on".into(),
            systems: "auto".into(),
            memory_budget: None,
            given: Vec::new(),
        }
    }

    /// The long names of the bake flags given on the command line of `matches`.
    pub(crate) fn given_in(matches: &clap::ArgMatches) -> Vec<String> {
        given_in::<Self>(matches)
    }
}

/// The probes' flags, which `bake` and `bake-plan` take beside the shared ones.
#[derive(Args, Debug, Clone)]
pub(crate) struct ProbeArgs {
    /// Light probes for moving objects and points off the surfaces: `auto` (a lattice of about
    /// 512 cells over the scene), `none`, a grid spacing in scene units, or a JSON file
    /// {"probes": [[x,y,z], ...]}; probes inside solid objects are dropped.
    #[arg(long, default_value = "auto", allow_negative_numbers = true)]
    pub(crate) probes: String,
    /// What the probes store: `auto` (their weights factored to a rank of a sixteenth of the
    /// patches, 128 to 512, where that makes the frame cheaper), `full` (every weight the
    /// rays found), or a rank.
    #[arg(long, default_value = "auto", allow_negative_numbers = true)]
    pub(crate) probe_rank: String,
}

/// The long names of the flags of `A` given on the command line of `matches`.
fn given_in<A: Args>(matches: &clap::ArgMatches) -> Vec<String> {
    use clap::parser::ValueSource;
    let cmd = A::augment_args(clap::Command::new("flags"));
    cmd.get_arguments()
        .filter(|a| {
            matches
                .try_get_raw(a.get_id().as_str())
                .is_ok_and(|v| v.is_some())
                && matches.value_source(a.get_id().as_str()) == Some(ValueSource::CommandLine)
        })
        .filter_map(|a| a.get_long().map(|l| format!("--{l}")))
        .collect()
}

impl ProbeArgs {
    /// The long names of the probes' flags given on the command line of `matches`.
    pub(crate) fn given_in(matches: &clap::ArgMatches) -> Vec<String> {
        given_in::<Self>(matches)
    }
}

/// `--patches N`: a whole number from 1 to [`radiosity_bake::limits::MAX_LEVEL_PATCHES`] (a negative or
/// zero count gets this message, not clap's "unexpected argument").
pub(crate) fn patch_count(s: &str) -> Result<usize, String> {
    let n: i128 = s
        .trim()
        .parse()
        .map_err(|_| format!("a patch count is a whole number, not {s:?}"))?;
    if n < 1 {
        return Err(format!("the patch count must be at least 1, not {n}"));
    }
    let n = usize::try_from(n).unwrap_or(usize::MAX);
    match radiosity_bake::limits::above_ceiling(n) {
        Some(why) => Err(why),
        None => Ok(n),
    }
}
