//! `[[materials]]`: presets, constitutive models with their parameters, plasticity, and the
//! `mpm-core` material each entry stands for.

use super::Checker;
use crate::solvers::SolverKind;
use mpm_core::material::{
    DruckerPrager, ElasticModel, FluidMaterial, Lame, Plasticity, Snow, SolidMaterial, Tait,
};
use mpm_core::Material;
use serde::{Deserialize, Serialize};

/// Material presets.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Preset {
    /// Weakly compressible water: K = 2e6 Pa, sound speed 44.7 m/s, at least 10× the flow
    /// speed √(2 g H) of a fall from up to H = 1 m.
    Water,
    /// Drucker–Prager sand.
    Sand,
    /// Snow plasticity.
    Snow,
    /// Soft elastic jelly.
    Jelly,
}

/// Constitutive model names.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ModelKind {
    /// Compressible Neo-Hookean.
    NeoHookean,
    /// Fixed-corotated.
    FixedCorotated,
    /// St. Venant–Kirchhoff on the Hencky strain.
    Hencky,
    /// Small-strain linear elasticity.
    LinearElastic,
    /// Stable Neo-Hookean.
    StableNeoHookean,
    /// Weakly compressible Tait fluid.
    Tait,
}

impl ModelKind {
    /// Whether the model is a fluid's.
    fn is_fluid(self) -> bool {
        self == ModelKind::Tait
    }
}

/// Plasticity names.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PlasticityKind {
    /// Purely elastic.
    None,
    /// Snow.
    Snow,
    /// Drucker–Prager sand.
    DruckerPrager,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawMaterial {
    name: String,
    preset: Option<Preset>,
    model: Option<ModelKind>,
    density: Option<f64>,
    #[serde(rename = "E")]
    e: Option<f64>,
    nu: Option<f64>,
    lambda: Option<f64>,
    mu: Option<f64>,
    plasticity: Option<PlasticityKind>,
    theta_c: Option<f64>,
    theta_s: Option<f64>,
    hardening: Option<f64>,
    friction_angle: Option<f64>,
    dp_hardening: Option<Vec<f64>>,
    cohesion: Option<f64>,
    volume_correction: Option<bool>,
    bulk_modulus: Option<f64>,
    gamma: Option<f64>,
    viscosity: Option<f64>,
}

/// One `[[materials]]` entry.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MaterialDef {
    /// Name referred to by bodies.
    pub name: String,
    /// The preset it started from, if any.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub preset: Option<Preset>,
    /// Model and parameters.
    #[serde(flatten)]
    pub model: ModelDef,
}

/// A constitutive model with its parameters.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(tag = "model", rename_all = "snake_case")]
pub enum ModelDef {
    /// Neo-Hookean solid.
    NeoHookean(SolidDef),
    /// Fixed-corotated solid.
    FixedCorotated(SolidDef),
    /// Hencky solid.
    Hencky(SolidDef),
    /// Linear elastic solid.
    LinearElastic(SolidDef),
    /// Stable Neo-Hookean solid.
    StableNeoHookean(SolidDef),
    /// Tait fluid.
    Tait(FluidDef),
}

/// Parameters of a solid.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SolidDef {
    /// Density (kg/m^D).
    pub density: f64,
    /// Young's modulus (Pa).
    #[serde(rename = "E")]
    pub e: f64,
    /// Poisson's ratio.
    pub nu: f64,
    /// First Lamé parameter (Pa); printed by `check` in the stage plan, not in the scene (the
    /// resolved scene gives E and nu, so that it is itself a valid scene).
    #[serde(skip)]
    pub lambda: f64,
    /// Shear modulus (Pa); see `lambda`.
    #[serde(skip)]
    pub mu: f64,
    /// Plasticity.
    #[serde(flatten)]
    pub plasticity: PlasticityDef,
}

/// Plasticity with its parameters.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(tag = "plasticity", rename_all = "snake_case")]
pub enum PlasticityDef {
    /// Purely elastic.
    None,
    /// Snow (Stomakhin et al. 2013).
    Snow {
        /// Critical compression θ_c.
        theta_c: f64,
        /// Critical stretch θ_s.
        theta_s: f64,
        /// Hardening coefficient ξ.
        hardening: f64,
    },
    /// Drucker–Prager (Klár et al. 2016).
    DruckerPrager {
        /// Friction-angle hardening h₀..h₃ (degrees, degrees, 1, degrees).
        dp_hardening: [f64; 4],
        /// Cohesion (dimensionless).
        cohesion: f64,
        /// Volume correction on or off.
        volume_correction: bool,
    },
}

/// Parameters of a fluid: a weakly compressible Tait fluid, or an incompressible one (for a
/// solver whose fluids are incompressible), which has no equation of state.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct FluidDef {
    /// Rest density (kg/m^D).
    pub density: f64,
    /// Bulk modulus (Pa); `None` for an incompressible fluid.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bulk_modulus: Option<f64>,
    /// Tait exponent γ; `None` for an incompressible fluid.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gamma: Option<f64>,
    /// Dynamic viscosity (Pa·s).
    pub viscosity: f64,
}

impl ModelDef {
    /// The `mpm-core` material.
    pub fn material(&self) -> Material {
        let solid = |s: &SolidDef, model: fn(Lame) -> ElasticModel| {
            Material::Solid(SolidMaterial {
                density: s.density,
                elastic: model(Lame {
                    mu: s.mu,
                    lambda: s.lambda,
                }),
                plasticity: match s.plasticity {
                    PlasticityDef::None => Plasticity::None,
                    PlasticityDef::Snow {
                        theta_c,
                        theta_s,
                        hardening,
                    } => Plasticity::Snow(Snow {
                        theta_c,
                        theta_s,
                        hardening,
                    }),
                    PlasticityDef::DruckerPrager {
                        dp_hardening,
                        cohesion,
                        volume_correction,
                    } => Plasticity::DruckerPrager(DruckerPrager {
                        h: dp_hardening,
                        cohesion,
                        volume_correction,
                    }),
                },
            })
        };
        match self {
            ModelDef::NeoHookean(s) => solid(s, ElasticModel::NeoHookean),
            ModelDef::FixedCorotated(s) => solid(s, ElasticModel::FixedCorotated),
            ModelDef::Hencky(s) => solid(s, ElasticModel::Hencky),
            ModelDef::LinearElastic(s) => solid(s, ElasticModel::LinearElastic),
            ModelDef::StableNeoHookean(s) => solid(s, ElasticModel::StableNeoHookean),
            // An incompressible fluid's solver never reads the equation of state; K = 0 gives it
            // none (zero pressure at any density) should anything else evaluate it.
            ModelDef::Tait(f) => Material::Fluid(FluidMaterial {
                density: f.density,
                eos: Tait {
                    bulk_modulus: f.bulk_modulus.unwrap_or(0.0),
                    gamma: f.gamma.unwrap_or(7.0),
                },
                viscosity: f.viscosity,
            }),
        }
    }
}

/// Resolves `[[materials]]`: at least one entry, with distinct names.
/// Most `[[materials]]` entries a scene may have: far more than any multi-material scene needs,
/// and a bound on what a scene can make `check` and the solvers allocate per material.
pub const MAX_MATERIALS: usize = 10_000;

pub(super) fn resolve_materials(
    c: &mut Checker<'_>,
    raw: &[RawMaterial],
    d: usize,
    solver: SolverKind,
) -> Vec<MaterialDef> {
    if raw.len() > MAX_MATERIALS {
        c.err(
            "materials",
            format!(
                "{} [[materials]] entries; at most {MAX_MATERIALS}",
                raw.len()
            ),
        );
        return Vec::new();
    }
    let materials: Vec<MaterialDef> = raw
        .iter()
        .enumerate()
        .map(|(i, m)| resolve_material(c, i, m, d, solver))
        .collect();
    if materials.is_empty() {
        c.err(
            "materials",
            "a scene needs at least one [[materials]] entry",
        );
    }
    let mut seen = std::collections::HashSet::new();
    for (i, m) in materials.iter().enumerate() {
        if !seen.insert(m.name.as_str()) {
            c.err(
                &format!("materials[{i}].name"),
                format!("duplicate material name \"{}\"", m.name),
            );
        }
    }
    materials
}

/// The materials of a scene by name, for lookups in constant time (so that resolving many
/// bodies stays linear in the scene size).
pub(crate) struct MaterialNames<'a> {
    /// The materials.
    defs: &'a [MaterialDef],
    /// Each name's first index.
    index: std::collections::HashMap<&'a str, usize>,
}

impl<'a> MaterialNames<'a> {
    /// Indexes `defs` by name.
    pub(crate) fn new(defs: &'a [MaterialDef]) -> Self {
        let mut index = std::collections::HashMap::new();
        for (i, m) in defs.iter().enumerate() {
            index.entry(m.name.as_str()).or_insert(i);
        }
        MaterialNames { defs, index }
    }

    /// The index of material `name`, or an error at `key` listing the materials.
    pub(crate) fn find(&self, c: &mut Checker<'_>, key: &str, name: &str) -> Option<usize> {
        let found = self.index.get(name).copied();
        if found.is_none() {
            unknown_material(c, key, name, self.defs);
        }
        found
    }
}

/// The index of material `name`, or an error at `key` listing the materials (one lookup; many
/// go through [`MaterialNames`]).
pub(crate) fn material_index(
    c: &mut Checker<'_>,
    key: &str,
    name: &str,
    materials: &[MaterialDef],
) -> Option<usize> {
    let found = materials.iter().position(|m| m.name == name);
    if found.is_none() {
        unknown_material(c, key, name, materials);
    }
    found
}

/// How many material names an "unknown material" error lists.
const LISTED_NAMES: usize = 20;

/// Reports at `key` that no material is called `name`, listing the first materials.
fn unknown_material(c: &mut Checker<'_>, key: &str, name: &str, materials: &[MaterialDef]) {
    let mut names: Vec<_> = materials
        .iter()
        .take(LISTED_NAMES)
        .map(|m| format!("\"{}\"", m.name))
        .collect();
    if materials.len() > LISTED_NAMES {
        names.push(format!("and {} more", materials.len() - LISTED_NAMES));
    }
    c.err(
        key,
        format!(
            "unknown material \"{name}\" (defined: {})",
            if names.is_empty() {
                "none".to_string()
            } else {
                names.join(", ")
            }
        ),
    );
}

/// Smallest accepted material density (kg/m³, in 2D kg/m²), far below any physical material
/// (aerogels are about 1 kg/m³): a density of, say, 1e-300 makes particle masses underflow to 0
/// and the stable time step vanish.
const MIN_DENSITY: f64 = 1e-6;

/// Whether the material is a fluid (`model = "tait"`).
pub(crate) fn is_fluid(m: &MaterialDef) -> bool {
    matches!(m.model, ModelDef::Tait(_))
}

/// The parameters of a preset, as if written in the scene.
fn preset_values(p: Preset) -> RawMaterial {
    let mut m = RawMaterial {
        name: String::new(),
        preset: None,
        model: None,
        density: None,
        e: None,
        nu: None,
        lambda: None,
        mu: None,
        plasticity: None,
        theta_c: None,
        theta_s: None,
        hardening: None,
        friction_angle: None,
        dp_hardening: None,
        cohesion: None,
        volume_correction: None,
        bulk_modulus: None,
        gamma: None,
        viscosity: None,
    };
    match p {
        Preset::Water => {
            m.model = Some(ModelKind::Tait);
            m.density = Some(1000.0);
            m.bulk_modulus = Some(2e6);
            m.gamma = Some(7.0);
            m.viscosity = Some(1e-3);
        }
        Preset::Sand => {
            m.model = Some(ModelKind::Hencky);
            m.density = Some(2200.0);
            m.e = Some(3.537e5);
            m.nu = Some(0.3);
            m.plasticity = Some(PlasticityKind::DruckerPrager);
        }
        Preset::Snow => {
            m.model = Some(ModelKind::FixedCorotated);
            m.density = Some(400.0);
            m.e = Some(1.4e5);
            m.nu = Some(0.2);
            m.plasticity = Some(PlasticityKind::Snow);
        }
        Preset::Jelly => {
            m.model = Some(ModelKind::StableNeoHookean);
            m.density = Some(1000.0);
            m.e = Some(5e4);
            m.nu = Some(0.3);
        }
    }
    m
}

fn resolve_material(
    c: &mut Checker<'_>,
    i: usize,
    m: &RawMaterial,
    d: usize,
    solver: SolverKind,
) -> MaterialDef {
    let k = |name: &str| format!("materials[{i}].{name}");
    if m.name.trim().is_empty() {
        c.err(&k("name"), "must not be empty");
    }
    let preset = m.preset.map(preset_values);
    let pick = |own: Option<f64>, from: fn(&RawMaterial) -> Option<f64>| {
        own.or_else(|| preset.as_ref().and_then(from))
    };
    let preset_model = preset.as_ref().and_then(|p| p.model);
    let model = match (m.model, preset_model) {
        (Some(own), Some(p)) if own.is_fluid() != p.is_fluid() => {
            c.err(
                &k("model"),
                format!(
                    "model {own:?} cannot override the model of preset {:?} (a {} preset)",
                    m.preset.unwrap_or(Preset::Water),
                    if p.is_fluid() { "fluid" } else { "solid" }
                ),
            );
            own
        }
        (Some(own), _) => own,
        (None, Some(p)) => p,
        (None, None) => {
            c.err(&k("model"), "missing key: give `model` or `preset`");
            ModelKind::NeoHookean
        }
    };
    let density = match pick(m.density, |p| p.density) {
        Some(rho) => c.num(
            &k("density"),
            rho,
            |x| x >= MIN_DENSITY,
            &format!(
                "must be a finite number ≥ {MIN_DENSITY} kg/m^{d} (lighter materials give particle \
                 masses and time steps the solvers cannot represent)"
            ),
        ),
        None => {
            c.err(&k("density"), "missing key: density (kg/m^D) is required");
            1.0
        }
    };
    let solid_keys: [(&str, bool); 12] = [
        ("E", m.e.is_some()),
        ("nu", m.nu.is_some()),
        ("lambda", m.lambda.is_some()),
        ("mu", m.mu.is_some()),
        ("plasticity", m.plasticity.is_some()),
        ("theta_c", m.theta_c.is_some()),
        ("theta_s", m.theta_s.is_some()),
        ("hardening", m.hardening.is_some()),
        ("friction_angle", m.friction_angle.is_some()),
        ("dp_hardening", m.dp_hardening.is_some()),
        ("cohesion", m.cohesion.is_some()),
        ("volume_correction", m.volume_correction.is_some()),
    ];
    let fluid_keys: [(&str, bool); 3] = [
        ("bulk_modulus", m.bulk_modulus.is_some()),
        ("gamma", m.gamma.is_some()),
        ("viscosity", m.viscosity.is_some()),
    ];
    let model_def = if model.is_fluid() {
        for (key, present) in solid_keys {
            c.not_applicable(&k(key), present, "to a fluid (model = \"tait\")");
        }
        let (bulk, gamma) = if crate::solvers::incompressible_fluid(solver) {
            let why = format!(
                "to a fluid of solver \"{}\", which is incompressible (no equation of state)",
                solver.name()
            );
            for (key, present) in &fluid_keys[..2] {
                c.not_applicable(&k(key), *present, &why);
            }
            (None, None)
        } else {
            let bulk = match pick(m.bulk_modulus, |p| p.bulk_modulus) {
                Some(b) => c.positive(&k("bulk_modulus"), b),
                None => {
                    c.err(
                        &k("bulk_modulus"),
                        "missing key: bulk_modulus (Pa) is required",
                    );
                    1.0
                }
            };
            let gamma = c.num(
                &k("gamma"),
                pick(m.gamma, |p| p.gamma).unwrap_or(7.0),
                |g| g > 1.0,
                "must be a finite number > 1",
            );
            (Some(bulk), Some(gamma))
        };
        let viscosity = c.non_negative(
            &k("viscosity"),
            pick(m.viscosity, |p| p.viscosity).unwrap_or(0.0),
        );
        ModelDef::Tait(FluidDef {
            density,
            bulk_modulus: bulk,
            gamma,
            viscosity,
        })
    } else {
        for (key, present) in fluid_keys {
            c.not_applicable(&k(key), present, "to a solid (only to model = \"tait\")");
        }
        let solid = resolve_solid(c, i, m, preset.as_ref(), density, d);
        match model {
            ModelKind::NeoHookean => ModelDef::NeoHookean(solid),
            ModelKind::FixedCorotated => ModelDef::FixedCorotated(solid),
            ModelKind::Hencky => ModelDef::Hencky(solid),
            ModelKind::LinearElastic => ModelDef::LinearElastic(solid),
            ModelKind::StableNeoHookean | ModelKind::Tait => ModelDef::StableNeoHookean(solid),
        }
    };
    MaterialDef {
        name: m.name.clone(),
        preset: m.preset,
        model: model_def,
    }
}

fn resolve_solid(
    c: &mut Checker<'_>,
    i: usize,
    m: &RawMaterial,
    preset: Option<&RawMaterial>,
    density: f64,
    d: usize,
) -> SolidDef {
    let k = |name: &str| format!("materials[{i}].{name}");
    let own_lame = m.lambda.is_some() || m.mu.is_some();
    let own_young = m.e.is_some() || m.nu.is_some();
    let (e, nu, lambda, mu) = if own_lame {
        if own_young {
            c.err(
                &k(if m.lambda.is_some() { "lambda" } else { "mu" }),
                "give either E and nu or lambda and mu, not both",
            );
        }
        let lambda = c.required(&k("lambda"), &m.lambda, "lambda (Pa) goes with mu");
        let mu = c.required(&k("mu"), &m.mu, "mu (Pa) goes with lambda");
        let (lambda, mu) = (lambda.unwrap_or(1.0), mu.unwrap_or(1.0));
        let mu = c.positive(&k("mu"), mu);
        // Positive bulk modulus: λ + 2μ/D > 0.
        c.num(
            &k("lambda"),
            lambda,
            |l| l + 2.0 * mu / d as f64 > 0.0,
            &format!("must satisfy lambda + 2 mu / {d} > 0 (positive bulk modulus)"),
        );
        let e = mu * (3.0 * lambda + 2.0 * mu) / (lambda + mu);
        let nu = lambda / (2.0 * (lambda + mu));
        (e, nu, lambda, mu)
    } else {
        let e = m.e.or(preset.and_then(|p| p.e));
        let nu = m.nu.or(preset.and_then(|p| p.nu));
        let e = match e {
            Some(e) => c.positive(&k("E"), e),
            None => {
                c.err(
                    &k("E"),
                    "missing key: give E (Pa) and nu, or lambda and mu (Pa)",
                );
                1.0
            }
        };
        let nu = match nu {
            Some(nu) => c.num(
                &k("nu"),
                nu,
                |v| v > -1.0 && v < 0.5,
                "Poisson's ratio must lie in (-1, 0.5)",
            ),
            None => {
                c.err(&k("nu"), "missing key: Poisson's ratio nu goes with E");
                0.3
            }
        };
        let lame = Lame::from_young_poisson(e, nu);
        (e, nu, lame.lambda, lame.mu)
    };
    let plasticity_kind = m
        .plasticity
        .or(preset.and_then(|p| p.plasticity))
        .unwrap_or(PlasticityKind::None);
    let snow_keys = [
        ("theta_c", m.theta_c.is_some()),
        ("theta_s", m.theta_s.is_some()),
        ("hardening", m.hardening.is_some()),
    ];
    let dp_keys = [
        ("friction_angle", m.friction_angle.is_some()),
        ("dp_hardening", m.dp_hardening.is_some()),
        ("cohesion", m.cohesion.is_some()),
        ("volume_correction", m.volume_correction.is_some()),
    ];
    let plasticity = match plasticity_kind {
        PlasticityKind::None => {
            for (key, present) in snow_keys.iter().chain(&dp_keys) {
                c.not_applicable(&k(key), *present, "without plasticity");
            }
            PlasticityDef::None
        }
        PlasticityKind::Snow => {
            for (key, present) in dp_keys {
                c.not_applicable(&k(key), present, "to snow plasticity");
            }
            PlasticityDef::Snow {
                theta_c: c.num(
                    &k("theta_c"),
                    m.theta_c.unwrap_or(2.5e-2),
                    |x| x > 0.0 && x < 1.0,
                    "must lie in (0, 1)",
                ),
                theta_s: c.non_negative(&k("theta_s"), m.theta_s.unwrap_or(7.5e-3)),
                hardening: c.non_negative(&k("hardening"), m.hardening.unwrap_or(10.0)),
            }
        }
        PlasticityKind::DruckerPrager => {
            for (key, present) in snow_keys {
                c.not_applicable(&k(key), present, "to Drucker-Prager plasticity");
            }
            let h = match (m.friction_angle, &m.dp_hardening) {
                (Some(_), Some(_)) => {
                    c.err(
                        &k("friction_angle"),
                        "give either friction_angle or dp_hardening, not both",
                    );
                    [35.0, 9.0, 0.2, 10.0]
                }
                (Some(phi), None) => {
                    let phi = c.num(
                        &k("friction_angle"),
                        phi,
                        |x| x > 0.0 && x < 90.0,
                        "must lie in (0, 90) degrees",
                    );
                    [phi, 0.0, 0.0, 0.0]
                }
                (None, Some(h)) => {
                    if h.len() != 4 {
                        c.err(
                            &k("dp_hardening"),
                            format!("must have 4 numbers [h0, h1, h2, h3], got {}", h.len()),
                        );
                        [35.0, 9.0, 0.2, 10.0]
                    } else {
                        let h = [h[0], h[1], h[2], h[3]];
                        if h.iter().any(|x| !x.is_finite()) {
                            c.err(&k("dp_hardening"), "must be finite numbers");
                        } else if h[2] < 0.0 {
                            c.err(&k("dp_hardening[2]"), "h2 must be ≥ 0");
                        } else {
                            let start = h[0] - h[3];
                            let end = h[0];
                            if !(start > 0.0 && start < 90.0 && end > 0.0 && end < 90.0) {
                                c.err(
                                    &k("dp_hardening"),
                                    format!(
                                        "the friction angle must stay in (0, 90) degrees: \
                                         h0 - h3 = {start}, h0 = {end}"
                                    ),
                                );
                            }
                        }
                        h
                    }
                }
                (None, None) => [35.0, 9.0, 0.2, 10.0],
            };
            PlasticityDef::DruckerPrager {
                dp_hardening: h,
                cohesion: c.non_negative(&k("cohesion"), m.cohesion.unwrap_or(0.0)),
                volume_correction: m.volume_correction.unwrap_or(true),
            }
        }
    };
    SolidDef {
        density,
        e,
        nu,
        lambda,
        mu,
        plasticity,
    }
}
