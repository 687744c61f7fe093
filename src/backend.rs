//! Backend choice at run time: `--backend`, else `RADIOSITY_BACKEND`, else `auto`
//! (`radiosity_backend_wgpu::choose`, which the C ABI shares). The choice, the reason and (for
//! the GPU) the adapter and decode path are printed on stderr; an unavailable backend is an
//! error that says why, never a silent fallback (only `auto` chooses).

use anyhow::bail;
use radiosity_backend_wgpu::{Backend, Chosen, GpuOptions, WgpuLevel};
use radiosity_core::{
    DecodeMode, EditedGather, Gather, RadFile, ReflectanceEdit, Rgb, TransferMatrix,
};
use radiosity_runtime::systems::Level;

/// The backend asked for and where the request came from.
fn requested(flag: Option<&str>) -> anyhow::Result<(Backend, String, &'static str)> {
    let env = std::env::var("RADIOSITY_BACKEND").ok();
    let (requested, source) = match (flag, env.as_deref()) {
        (Some(f), _) => (f.to_owned(), "--backend"),
        (None, Some(e)) if !e.is_empty() => (e.to_owned(), "RADIOSITY_BACKEND"),
        _ => ("auto".to_owned(), "default"),
    };
    let Some(backend) = Backend::from_name(&requested) else {
        bail!("unknown backend {requested:?} (from {source}): use auto, cpu, gpu or reference");
    };
    Ok((backend, requested, source))
}

/// Refuses a level file (`.rad` version 3, its transfer split into systems) for a command
/// that lights one matrix only (`render`, a reflectance edit, `--export-dds`): one line that
/// says what does light it.
pub(crate) fn refuse_level(file: &RadFile<'_>, what: &str) -> anyhow::Result<()> {
    if let Some(sys) = &file.systems {
        bail!(
            "{what} does not take a level file ({} systems, no one-matrix transfer); light it with `radiosity solve LEVEL.rad`",
            sys.count()
        );
    }
    Ok(())
}

/// A level lit on the CPU or the reference backend (one gather a system, the light between
/// systems through the threaded coupling product) or on the GPU (every system and the
/// coupling on one device: `WgpuLevel`).
pub(crate) enum LevelLight {
    Systems(Level<Box<dyn Gather>>),
    Gpu(WgpuLevel),
}

impl LevelLight {
    /// The level as a gather ([`Gather::gather`]: to the steady state from the light it
    /// holds).
    pub(crate) fn gather_mut(&mut self) -> &mut dyn Gather {
        match self {
            LevelLight::Systems(l) => l,
            LevelLight::Gpu(l) => l,
        }
    }

    /// Frames to a relative change of at most `tolerance`, or `max_frames`.
    pub(crate) fn steady(
        &mut self,
        first: &[Rgb],
        tolerance: f32,
        max_frames: usize,
    ) -> anyhow::Result<usize> {
        Ok(match self {
            LevelLight::Systems(l) => l.steady(first, tolerance, max_frames)?,
            LevelLight::Gpu(l) => l.steady(first, tolerance, max_frames)?,
        })
    }

    /// The gathered irradiance after the last frame.
    pub(crate) fn gathered(&self) -> &[Rgb] {
        match self {
            LevelLight::Systems(l) => l.gathered(),
            LevelLight::Gpu(l) => l.gathered(),
        }
    }

    /// Systems.
    pub(crate) fn count(&self) -> usize {
        match self {
            LevelLight::Systems(l) => l.count(),
            LevelLight::Gpu(l) => l.count(),
        }
    }

    /// Patch `i` reflects `rho` from now on ([`Level::set_reflectance`]); a GPU level takes
    /// no edits (`choose_level` refuses them), so it is left as baked.
    pub(crate) fn set_reflectance(&mut self, i: usize, rho: Rgb) {
        if let LevelLight::Systems(l) = self {
            l.set_reflectance(i, rho);
        }
    }

    /// The last frame's relative change.
    pub(crate) fn change(&self) -> f32 {
        match self {
            LevelLight::Systems(l) => l.change(),
            LevelLight::Gpu(l) => l.change(),
        }
    }
}

/// A level lit on the chosen backend, with the backend's name and the gather's.
pub(crate) type ChosenLevel = (LevelLight, &'static str, String);

/// A level file ready to light (`solve`) on the requested backend: `gpu` on one device
/// (`WgpuLevel`), `auto` there where a hardware GPU is found, else (and for `cpu` and
/// `reference`) one gather a system with the light between systems on the CPU. `edits`
/// (level patch, new reflectance) go into the systems' own gathers (`EditedGather`, on the
/// CPU or reference backend only); the caller sets the level's reflectance after.
pub(crate) fn choose_level(
    flag: Option<&str>,
    file: &RadFile<'_>,
    edits: &[(u32, Rgb)],
) -> anyhow::Result<ChosenLevel> {
    let (backend, requested, source) = requested(flag)?;
    let sys = file.systems.as_ref();
    let systems = |backend: Backend, why: String| -> anyhow::Result<ChosenLevel> {
        let mut name = String::new();
        let level = Level::new(file, |s, one| {
            let chosen =
                radiosity_backend_wgpu::choose(backend, one.matrix.clone().into_owned(), &why)
                    .map_err(|e| anyhow::anyhow!("backend {requested} (from {source}): {}", e.0))?;
            if s == 0 {
                name = format!("{}-systems", chosen.gather.name());
            }
            // This system's share of the edits, in its own numbering.
            let r = sys.map_or(0..0, |l| l.range(s));
            let mine: Vec<(u32, Rgb)> = edits
                .iter()
                .filter(|(i, _)| r.contains(&(*i as usize)))
                .map(|&(i, rho)| (i - r.start as u32, rho))
                .collect();
            if mine.is_empty() {
                return Ok::<_, anyhow::Error>(chosen.gather);
            }
            let edit = ReflectanceEdit::new(&one.matrix, DecodeMode::D3d10, &one.patches, &mine)
                .map_err(|e| anyhow::anyhow!("materials, system {s}: {e}"))?;
            let edited = EditedGather::new(chosen.gather, edit)
                .map_err(|e| anyhow::anyhow!("materials, system {s}: {e}"))?;
            Ok(Box::new(edited) as Box<dyn Gather>)
        })
        .map_err(|e| match e {
            radiosity_runtime::systems::LevelError::Gather(_, e) => e,
            other => anyhow::anyhow!("{other}"),
        })?;
        let kind = if backend == Backend::Reference {
            "reference"
        } else {
            "cpu"
        };
        eprintln!(
            "backend: {kind} ({} systems of a level; {why})",
            level.count()
        );
        Ok((LevelLight::Systems(level), kind, name))
    };
    let gpu = |level: WgpuLevel, why: &str| -> anyhow::Result<ChosenLevel> {
        eprintln!(
            "backend: gpu ({} systems of a level on one device; {why})",
            level.count()
        );
        let name = level.name().to_owned();
        Ok((LevelLight::Gpu(level), "gpu", name))
    };
    let options = GpuOptions::default();
    if !edits.is_empty() {
        return match backend {
            Backend::Gpu => bail!(
                "a reflectance edit (--materials) of a level runs on the cpu or reference backend, not on the gpu (from {source})"
            ),
            Backend::Auto => systems(
                Backend::Cpu,
                "auto: a level's reflectance edit runs on the CPU".into(),
            ),
            other => systems(other, format!("requested by {source}")),
        };
    }
    match backend {
        Backend::Gpu => match WgpuLevel::new(file, &options) {
            Ok(level) => gpu(level, &format!("requested by {source}")),
            Err(e) => bail!("backend gpu (from {source}) is not available: {e}"),
        },
        Backend::Auto => match radiosity_backend_wgpu::auto_level(file, &options) {
            Ok(level) => gpu(level, "auto: a hardware GPU is present"),
            Err(reason) => systems(Backend::Cpu, reason),
        },
        other => systems(other, format!("requested by {source}")),
    }
}

pub(crate) fn choose(
    flag: Option<&str>,
    matrix: TransferMatrix<'static>,
) -> anyhow::Result<Chosen> {
    let (backend, _, source) = requested(flag)?;
    let chosen = radiosity_backend_wgpu::choose(backend, matrix, &format!("requested by {source}"))
        .map_err(|e| anyhow::anyhow!("backend gpu (from {source}) is not available: {}", e.0))?;
    eprintln!("backend: {} ({})", chosen.gather.name(), chosen.detail);
    Ok(chosen)
}
