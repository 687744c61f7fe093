//! Finding adapters: list them all, rank them, pick one by rule, index or name.

use std::fmt;

/// What kind of device an adapter drives.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DeviceKind {
    /// A discrete GPU.
    Discrete,
    /// A GPU sharing the CPU's memory.
    Integrated,
    /// A GPU seen through a hypervisor.
    Virtual,
    /// A software rasteriser on the CPU (llvmpipe, lavapipe, WARP, SwiftShader).
    Cpu,
    /// Anything the driver does not say.
    Other,
}

impl DeviceKind {
    fn from_wgpu(t: wgpu::DeviceType) -> Self {
        match t {
            wgpu::DeviceType::DiscreteGpu => DeviceKind::Discrete,
            wgpu::DeviceType::IntegratedGpu => DeviceKind::Integrated,
            wgpu::DeviceType::VirtualGpu => DeviceKind::Virtual,
            wgpu::DeviceType::Cpu => DeviceKind::Cpu,
            wgpu::DeviceType::Other => DeviceKind::Other,
        }
    }

    /// A short lower-case name (`"discrete"`, `"cpu"`, …).
    pub fn name(self) -> &'static str {
        match self {
            DeviceKind::Discrete => "discrete",
            DeviceKind::Integrated => "integrated",
            DeviceKind::Virtual => "virtual",
            DeviceKind::Cpu => "cpu",
            DeviceKind::Other => "other",
        }
    }
}

/// One adapter as the system reports it.
#[derive(Clone, Debug)]
pub struct AdapterInfo {
    /// Position in [`adapters`]'s list (stable within one process).
    pub index: usize,
    /// The driver's name for the device (`"llvmpipe (LLVM 15.0.6, 256 bits)"`, `"NVIDIA H100"`).
    pub name: String,
    /// The API wgpu drives it through (`"vulkan"`, `"gl"`, `"metal"`, `"dx12"`).
    pub backend: String,
    /// What kind of device it is.
    pub kind: DeviceKind,
    /// The driver and its version, as reported.
    pub driver: String,
    /// Whether the texture unit decodes BC1/BC4 (`TEXTURE_COMPRESSION_BC`).
    pub bc: bool,
}

impl AdapterInfo {
    /// Whether this is a GPU rather than a software rasteriser (any kind but [`DeviceKind::Cpu`]).
    pub fn is_hardware(&self) -> bool {
        self.kind != DeviceKind::Cpu
    }

    /// Whether the driver is Mesa's llvmpipe/lavapipe, whose BC decoder
    /// [`radiosity_core::DecodeMode::Mesa`] models bit for bit.
    pub fn is_mesa_software(&self) -> bool {
        let s = format!("{} {}", self.name, self.driver).to_ascii_lowercase();
        self.kind == DeviceKind::Cpu && (s.contains("llvmpipe") || s.contains("lavapipe"))
    }

    /// Ranking for [`AdapterChoice::Best`]: hardware before software, discrete first; native
    /// APIs before GL.
    fn rank(&self) -> (u8, u8) {
        let kind = match self.kind {
            DeviceKind::Discrete => 0,
            DeviceKind::Integrated => 1,
            DeviceKind::Virtual => 2,
            DeviceKind::Other => 3,
            DeviceKind::Cpu => 4,
        };
        (kind, u8::from(self.backend == "gl"))
    }
}

impl fmt::Display for AdapterInfo {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} ({}, {}", self.name, self.backend, self.kind.name())?;
        if !self.driver.is_empty() {
            write!(f, ", {}", self.driver)?;
        }
        f.write_str(")")
    }
}

/// Which adapter a gather runs on.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum AdapterChoice {
    /// The best adapter there is: a hardware GPU if any (discrete first), else a software one.
    #[default]
    Best,
    /// The best hardware GPU; none (only software rasterisers, or nothing) is an error.
    Hardware,
    /// The adapter at this position of [`adapters`].
    Index(usize),
    /// The best adapter whose name, driver or backend contains this text (case-insensitive).
    Name(String),
}

impl fmt::Display for AdapterChoice {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            AdapterChoice::Best => f.write_str("best adapter"),
            AdapterChoice::Hardware => f.write_str("hardware GPU"),
            AdapterChoice::Index(i) => write!(f, "adapter #{i}"),
            AdapterChoice::Name(s) => write!(f, "adapter matching {s:?}"),
        }
    }
}

/// An adapter found on this system, ready to open a device on.
#[derive(Clone, Debug)]
pub struct Adapter {
    pub(crate) inner: wgpu::Adapter,
    /// What it is.
    pub info: AdapterInfo,
}

impl Adapter {
    /// The wgpu adapter, for opening devices of one's own on it (the examples' probes).
    pub fn wgpu_adapter(&self) -> &wgpu::Adapter {
        &self.inner
    }
}

fn instance() -> wgpu::Instance {
    // `with_env` honours WGPU_BACKEND (e.g. `vulkan` or `gl`) to restrict the search.
    wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle().with_env())
}

/// Every adapter wgpu finds on every backend compiled in (Vulkan, GL, Metal, DX12), in the
/// order [`AdapterChoice::Best`] ranks them.
pub fn adapters() -> Vec<Adapter> {
    let found = pollster::block_on(instance().enumerate_adapters(wgpu::Backends::all()));
    let mut list: Vec<Adapter> = found
        .into_iter()
        .map(|a| {
            let i = a.get_info();
            let info = AdapterInfo {
                index: 0,
                name: i.name,
                backend: i.backend.to_str().to_owned(),
                kind: DeviceKind::from_wgpu(i.device_type),
                driver: [i.driver, i.driver_info]
                    .into_iter()
                    .filter(|s| !s.is_empty())
                    .collect::<Vec<_>>()
                    .join(" "),
                bc: a
                    .features()
                    .contains(wgpu::Features::TEXTURE_COMPRESSION_BC),
            };
            Adapter { inner: a, info }
        })
        .collect();
    list.sort_by_key(|a| a.info.rank());
    for (i, a) in list.iter_mut().enumerate() {
        a.info.index = i;
    }
    list
}

/// The adapter `choice` names, or a one-line reason why there is none.
pub fn choose_adapter(choice: &AdapterChoice) -> Result<Adapter, String> {
    let list = adapters();
    let names = || {
        if list.is_empty() {
            "no adapter at all (on Debian: apt-get install mesa-vulkan-drivers libvulkan1 gives the software Vulkan driver)".to_owned()
        } else {
            let all: Vec<String> = list
                .iter()
                .map(|a| format!("#{} {}", a.info.index, a.info))
                .collect();
            format!("adapters: {}", all.join("; "))
        }
    };
    let found = match choice {
        AdapterChoice::Best => list.first(),
        AdapterChoice::Hardware => list.iter().find(|a| a.info.is_hardware()),
        AdapterChoice::Index(i) => list.get(*i),
        AdapterChoice::Name(s) => {
            let s = s.to_ascii_lowercase();
            list.iter().find(|a| {
                format!("{} {} {}", a.info.name, a.info.driver, a.info.backend)
                    .to_ascii_lowercase()
                    .contains(&s)
            })
        }
    };
    found
        .cloned()
        .ok_or_else(|| format!("no {choice}: {}", names()))
}
