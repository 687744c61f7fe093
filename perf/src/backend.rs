//! The gather backend a program lights a file with, chosen at run time: a flag (`--backend`),
//! else `RADIOSITY_BACKEND`, else `auto` ([`Request`]), built by
//! [`radiosity_backend_wgpu::choose`] (which the C ABI shares) for one matrix, or over a level's
//! systems ([`choose_level`]). What was chosen and why comes back with the gather, for the
//! caller to show; an unavailable backend is an error that says why, never a silent fallback
//! (only `auto` chooses).

use anyhow::{anyhow, bail};
pub use radiosity_backend_wgpu::{Backend, Chosen};
use radiosity_backend_wgpu::{GpuOptions, WgpuLevel};
use radiosity_core::{
    DecodeMode, EditedGather, Gather, RadFile, ReflectanceEdit, Rgb, TransferMatrix,
};
use radiosity_runtime::systems::Level;

/// The environment variable that names the backend when no flag does.
pub const ENV: &str = "RADIOSITY_BACKEND";

/// The backend asked for and where the request came from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Request {
    /// The backend.
    pub backend: Backend,
    /// Its name as given (`auto`, `cpu`, `gpu`, `reference`).
    pub name: String,
    /// Where it came from: `--backend`, `RADIOSITY_BACKEND` or `default`.
    pub source: &'static str,
}

impl Request {
    /// The backend of `flag` (the `--backend` value), else of `env` (the value of
    /// [`ENV`], ignored when empty), else `auto`. An unknown name is an error that names
    /// where it came from.
    pub fn new(flag: Option<&str>, env: Option<&str>) -> anyhow::Result<Self> {
        let (name, source) = match (flag, env) {
            (Some(f), _) => (f.to_owned(), "--backend"),
            (None, Some(e)) if !e.is_empty() => (e.to_owned(), ENV),
            _ => ("auto".to_owned(), "default"),
        };
        let Some(backend) = Backend::from_name(&name) else {
            bail!("unknown backend {name:?} (from {source}): use auto, cpu, gpu or reference");
        };
        Ok(Request {
            backend,
            name,
            source,
        })
    }

    /// [`Request::new`] with [`ENV`] read from this process's environment.
    pub fn from_env(flag: Option<&str>) -> anyhow::Result<Self> {
        Self::new(flag, std::env::var(ENV).ok().as_deref())
    }
}

/// The gather of `request` over one matrix; its `kind`, `detail` and the gather's name say
/// what runs and why.
pub fn choose(request: &Request, matrix: TransferMatrix<'static>) -> anyhow::Result<Chosen> {
    let source = request.source;
    radiosity_backend_wgpu::choose(request.backend, matrix, &format!("requested by {source}"))
        .map_err(|e| anyhow!("backend gpu (from {source}) is not available: {}", e.0))
}

/// Refuses a level file (`.rad` version 3, its transfer split into systems) for a use that
/// lights one matrix only (`what`: rendering, a reflectance edit, a DDS export): one line that
/// says what does light it.
pub fn refuse_level(file: &RadFile<'_>, what: &str) -> anyhow::Result<()> {
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
pub enum LevelLight {
    /// One gather a system, the coupling on the CPU.
    Systems(Level<Box<dyn Gather>>),
    /// Every system and the coupling on one device.
    Gpu(WgpuLevel),
}

impl LevelLight {
    /// The level as a gather ([`Gather::gather`]: to the steady state from the light it
    /// holds).
    pub fn gather_mut(&mut self) -> &mut dyn Gather {
        match self {
            LevelLight::Systems(l) => l,
            LevelLight::Gpu(l) => l,
        }
    }

    /// Frames to a relative change of at most `tolerance`, or `max_frames`.
    pub fn steady(
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
    pub fn gathered(&self) -> &[Rgb] {
        match self {
            LevelLight::Systems(l) => l.gathered(),
            LevelLight::Gpu(l) => l.gathered(),
        }
    }

    /// Systems.
    pub fn count(&self) -> usize {
        match self {
            LevelLight::Systems(l) => l.count(),
            LevelLight::Gpu(l) => l.count(),
        }
    }

    /// Patch `i` reflects `rho` from now on ([`Level::set_reflectance`]); a GPU level takes
    /// no edits ([`choose_level`] refuses them), so it is left as baked.
    pub fn set_reflectance(&mut self, i: usize, rho: Rgb) {
        if let LevelLight::Systems(l) = self {
            l.set_reflectance(i, rho);
        }
    }

    /// The last frame's relative change.
    pub fn change(&self) -> f32 {
        match self {
            LevelLight::Systems(l) => l.change(),
            LevelLight::Gpu(l) => l.change(),
        }
    }
}

/// A level lit on the chosen backend.
pub struct ChosenLevel {
    /// The level's light.
    pub light: LevelLight,
    /// `cpu`, `gpu` or `reference`.
    pub kind: &'static str,
    /// The gather's name (`<cpu gather>-systems`, or the GPU level's).
    pub name: String,
    /// Why this backend.
    pub why: String,
}

impl ChosenLevel {
    /// What runs and why, in one line: `gpu (12 systems of a level on one device; auto: a
    /// hardware GPU is present)`.
    pub fn summary(&self) -> String {
        let on = match self.light {
            LevelLight::Gpu(_) => " on one device",
            LevelLight::Systems(_) => "",
        };
        format!(
            "{} ({} systems of a level{on}; {})",
            self.kind,
            self.light.count(),
            self.why
        )
    }
}

/// A level file ready to light on the requested backend: `gpu` on one device
/// (`WgpuLevel`), `auto` there where a hardware GPU is found, else (and for `cpu` and
/// `reference`) one gather a system with the light between systems on the CPU. `edits`
/// (level patch, new reflectance) go into the systems' own gathers (`EditedGather`, on the
/// CPU or reference backend only); the caller sets the level's reflectance after.
pub fn choose_level(
    request: &Request,
    file: &RadFile<'_>,
    edits: &[(u32, Rgb)],
) -> anyhow::Result<ChosenLevel> {
    let source = request.source;
    if !edits.is_empty() {
        return match request.backend {
            Backend::Gpu => bail!(
                "a reflectance edit (--materials) of a level runs on the cpu or reference backend, not on the gpu (from {source})"
            ),
            Backend::Auto => systems_level(
                request,
                Backend::Cpu,
                file,
                edits,
                "auto: a level's reflectance edit runs on the CPU".into(),
            ),
            other => systems_level(
                request,
                other,
                file,
                edits,
                format!("requested by {source}"),
            ),
        };
    }
    let options = GpuOptions::default();
    let gpu = |level: WgpuLevel, why: String| ChosenLevel {
        name: level.name().to_owned(),
        light: LevelLight::Gpu(level),
        kind: "gpu",
        why,
    };
    match request.backend {
        Backend::Gpu => match WgpuLevel::new(file, &options) {
            Ok(level) => Ok(gpu(level, format!("requested by {source}"))),
            Err(e) => bail!("backend gpu (from {source}) is not available: {e}"),
        },
        Backend::Auto => match radiosity_backend_wgpu::auto_level(file, &options) {
            Ok(level) => Ok(gpu(level, "auto: a hardware GPU is present".into())),
            Err(reason) => systems_level(request, Backend::Cpu, file, &[], reason),
        },
        other => systems_level(request, other, file, &[], format!("requested by {source}")),
    }
}

/// One `backend` gather a system of `file`, each carrying its share of `edits`.
fn systems_level(
    request: &Request,
    backend: Backend,
    file: &RadFile<'_>,
    edits: &[(u32, Rgb)],
    why: String,
) -> anyhow::Result<ChosenLevel> {
    let sys = file.systems.as_ref();
    let mut name = String::new();
    let level = Level::new(file, |s, one| {
        let chosen = radiosity_backend_wgpu::choose(backend, one.matrix.clone().into_owned(), &why)
            .map_err(|e| {
                anyhow!(
                    "backend {} (from {}): {}",
                    request.name,
                    request.source,
                    e.0
                )
            })?;
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
            .map_err(|e| anyhow!("materials, system {s}: {e}"))?;
        let edited = EditedGather::new(chosen.gather, edit)
            .map_err(|e| anyhow!("materials, system {s}: {e}"))?;
        Ok(Box::new(edited) as Box<dyn Gather>)
    })
    .map_err(|e| match e {
        radiosity_runtime::systems::LevelError::Gather(_, e) => e,
        other => anyhow!("{other}"),
    })?;
    let kind = if backend == Backend::Reference {
        "reference"
    } else {
        "cpu"
    };
    Ok(ChosenLevel {
        light: LevelLight::Systems(level),
        kind,
        name,
        why,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use radiosity_core::Format;
    use radiosity_tests::fixtures::sample_file;

    #[test]
    fn the_flag_beats_the_environment_which_beats_auto() {
        let r = Request::new(Some("cpu"), Some("gpu")).unwrap();
        assert_eq!((r.backend, r.source), (Backend::Cpu, "--backend"));
        let r = Request::new(None, Some("reference")).unwrap();
        assert_eq!((r.backend, r.source), (Backend::Reference, ENV));
        // An empty variable is as good as none.
        let r = Request::new(None, Some("")).unwrap();
        assert_eq!(
            (r.backend, r.name.as_str(), r.source),
            (Backend::Auto, "auto", "default")
        );
    }

    #[test]
    fn an_unknown_backend_says_where_it_came_from() {
        let e = Request::new(None, Some("tpu")).unwrap_err().to_string();
        assert!(e.contains("\"tpu\"") && e.contains(ENV), "{e}");
        let e = Request::new(Some("fast"), None).unwrap_err().to_string();
        assert!(e.contains("--backend") && e.contains("auto, cpu"), "{e}");
    }

    #[test]
    fn cpu_and_reference_are_built_as_asked_and_say_why() {
        let file = sample_file(37, 3, Format::Bc1, 16);
        for (name, kind) in [("cpu", "cpu"), ("reference", "reference")] {
            let r = Request::new(Some(name), None).unwrap();
            let chosen = choose(&r, file.matrix.clone()).unwrap();
            assert_eq!(chosen.kind, kind);
            assert!(
                chosen.detail.contains("requested by --backend"),
                "{}",
                chosen.detail
            );
        }
        // A one-matrix file is not a level: nothing to refuse.
        refuse_level(&file, "rendering").unwrap();
    }
}
