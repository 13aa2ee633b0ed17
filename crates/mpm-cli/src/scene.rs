//! The scene format: TOML in SI units (documented key by key in `docs/scenes.md`).
//!
//! A scene is read in two passes. Serde reads the file into `Raw*` structs that reject unknown
//! keys and wrong types (the TOML parser gives their span). Then [`resolve`] checks every value,
//! fills in defaults and presets, and produces a [`Scene`]; each problem it finds names its key
//! path (e.g. `materials[1].E`) and the key's span in the file, found through a [`SpanIndex`].
//! [`Scene`] serialises back to TOML in the same format with every default filled in, which is
//! what `mpm-cli check` prints.

use crate::error::{CliError, Diagnostic, SceneError};
use crate::span::SpanIndex;
use mpm_core::material::{
    DruckerPrager, ElasticModel, FluidMaterial, Lame, Parameter, Plasticity, Snow, SolidMaterial,
    Tait,
};
use mpm_core::{Columns, Material};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

mod tlmpm;
pub use tlmpm::{
    FixedDef, IntegratorKind, LinearSolverKind, LoadDef, ProjectionKind, ReferenceUpdateDef,
    TlmpmDef,
};

// ------------------------------------------------------------------------------------------
// Keyword enums shared by the raw and resolved forms.
// ------------------------------------------------------------------------------------------

/// Which solver runs the scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SolverKind {
    /// Explicit MLS-MPM (`mpm-explicit`).
    Explicit,
    /// Total-Lagrangian MPM (`mpm-tlmpm`), implicit or explicit; see `[tlmpm]`.
    Tlmpm,
    /// DIQ-MPM (not available yet).
    Diq,
}

/// What to do when a guard check fails.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum InstabilityAction {
    /// Stop with exit code 3.
    Abort,
    /// Retry the step with dt/2, up to `max_retries` times.
    Retry,
}

/// Particle–grid transfer scheme.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TransferKind {
    /// APIC / MLS (affine) transfer.
    Apic,
    /// PIC.
    Pic,
    /// FLIP/PIC blend.
    Flip,
}

/// Interpolation kernel.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum KernelKind {
    /// Linear B-spline.
    Linear,
    /// Quadratic B-spline.
    Quadratic,
    /// Cubic B-spline.
    Cubic,
}

/// How fluid volumes evolve.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum VolumeUpdateKind {
    /// Integrate J from the velocity gradient.
    Deformation,
    /// Re-estimate J from the grid density every step.
    Reestimate,
}

/// Where initial particle volumes come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum InitialVolume {
    /// The volume each sample represents.
    Sampling,
    /// Grid density estimation (multigrid paper Eq. 4): `V_p = m_p/ρ_p`.
    Density,
}

/// Material presets.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Preset {
    /// Weakly compressible water.
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

/// Body shape names.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ShapeKind {
    /// Axis-aligned box.
    Box,
    /// Sphere (disk in 2D).
    Sphere,
    /// Cylinder (a rectangle in 2D).
    Cylinder,
    /// Closed triangle mesh from an OBJ file (3D only).
    Mesh,
}

/// Sampling names.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SamplingKind {
    /// Regular lattice, optionally jittered.
    Lattice,
    /// Poisson-disk sampling.
    Poisson,
}

/// Boundary kinds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BoundaryKind {
    /// The walls of the grid box.
    Walls,
    /// A half-space collider.
    HalfSpace,
    /// A box collider.
    Box,
    /// A sphere collider.
    Sphere,
}

/// Contact rules.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ContactName {
    /// No relative motion.
    Sticky,
    /// No normal relative motion.
    Slip,
    /// No approaching normal motion.
    Separate,
}

/// How the grids of two phases exchange momentum (multigrid paper §4.1–4.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CouplingName {
    /// Single-grid coupling: both phases take the mass-weighted mean velocity.
    Full,
    /// Drag (Eqs. 14, 17).
    Drag,
    /// Contact with normal share β and friction δ (Eqs. 24–30).
    Contact,
}

/// Tangential force rule of a contact coupling.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FrictionModel {
    /// Coulomb cone (Eq. 30): the tangential force is at most δ times the normal force.
    Coulomb,
    /// The tangential force is δ times the tangential collision force.
    Proportional,
}

/// When a contact coupling applies.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ApplyName {
    /// Only where the phases approach each other along the interface normal.
    OnApproach,
    /// At every node where both phases have mass.
    Always,
}

/// Update rules of the effective volume fraction φ_eff.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PhiEffRule {
    /// φ_eff = φ.
    Current,
    /// Eq. 21: φ_eff ← max(φ_eff, φ).
    Max,
    /// Eq. 22: φ_eff ← (1 − α) φ_eff + α φ, α = min(1, rate·dt).
    Relax,
    /// Eq. 36: φ_eff ← max(φ_eff, (1 − α) φ_eff + α φ).
    MaxRelax,
}

/// Discretisations of the concentration Laplacian.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SchemeName {
    /// Galerkin form with kernel gradients (conservative).
    KernelGradient,
    /// The paper's MLS difference form (Eqs. 34–35).
    MlsDifference,
}

/// A number or a list of numbers (mesh scale, angular velocity).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum NumberOrList {
    /// One number.
    Number(f64),
    /// A list of numbers.
    List(Vec<f64>),
}

// ------------------------------------------------------------------------------------------
// Raw (as written) form.
// ------------------------------------------------------------------------------------------

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScene {
    simulation: RawSimulation,
    grid: RawGrid,
    #[serde(default)]
    materials: Vec<RawMaterial>,
    #[serde(default)]
    bodies: Vec<RawBody>,
    #[serde(default)]
    boundaries: Vec<RawBoundary>,
    #[serde(default)]
    couplings: Vec<RawCoupling>,
    porous: Option<RawPorous>,
    mixing: Option<RawMixing>,
    dissolution: Option<RawDissolution>,
    output: Option<RawOutput>,
    checkpoint: Option<RawCheckpoint>,
    tlmpm: Option<tlmpm::RawTlmpm>,
    #[serde(default)]
    fixed: Vec<tlmpm::RawFixed>,
    #[serde(default)]
    loads: Vec<tlmpm::RawLoad>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSimulation {
    dim: u32,
    solver: Option<SolverKind>,
    end_time: Option<f64>,
    steps: Option<u64>,
    cfl: Option<f64>,
    dt_max: Option<f64>,
    dt_min: Option<f64>,
    dt: Option<f64>,
    gravity: Option<Vec<f64>>,
    on_instability: Option<InstabilityAction>,
    max_retries: Option<u32>,
    transfer: Option<TransferKind>,
    flip_blend: Option<f64>,
    volume_update: Option<VolumeUpdateKind>,
    initial_volume: Option<InitialVolume>,
    soft_walls: Option<RawSoftWalls>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSoftWalls {
    margin: f64,
    lookahead: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawGrid {
    min: Vec<f64>,
    max: Vec<f64>,
    dx: f64,
    kernel: Option<KernelKind>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMaterial {
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

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawBody {
    name: Option<String>,
    material: String,
    phase: Option<u32>,
    shape: ShapeKind,
    min: Option<Vec<f64>>,
    max: Option<Vec<f64>>,
    center: Option<Vec<f64>>,
    radius: Option<f64>,
    axis: Option<Vec<f64>>,
    half_length: Option<f64>,
    file: Option<String>,
    scale: Option<NumberOrList>,
    rotation: Option<Vec<f64>>,
    translation: Option<Vec<f64>>,
    sampling: Option<SamplingKind>,
    per_axis: Option<u32>,
    jitter: Option<f64>,
    seed: Option<u64>,
    poisson_radius: Option<f64>,
    velocity: Option<Vec<f64>>,
    velocity_gradient: Option<Vec<Vec<f64>>>,
    angular_velocity: Option<NumberOrList>,
    about: Option<Vec<f64>>,
    initial_phi_eff: Option<f64>,
    concentration: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawBoundary {
    #[serde(rename = "type")]
    kind: BoundaryKind,
    contact: Option<ContactName>,
    friction: Option<f64>,
    velocity: Option<Vec<f64>>,
    thickness: Option<u32>,
    point: Option<Vec<f64>>,
    normal: Option<Vec<f64>>,
    min: Option<Vec<f64>>,
    max: Option<Vec<f64>>,
    center: Option<Vec<f64>>,
    radius: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCoupling {
    phases: Vec<u32>,
    kind: CouplingName,
    coefficient: Option<f64>,
    porosity: Option<f64>,
    conductivity: Option<f64>,
    normal_share: Option<f64>,
    friction: Option<f64>,
    friction_model: Option<FrictionModel>,
    apply: Option<ApplyName>,
    buoyancy: Option<f64>,
    pressure_buoyancy: Option<bool>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPorous {
    phi_eff: Option<PhiEffRule>,
    rate: Option<f64>,
    initial_phi_eff: Option<f64>,
    #[serde(default)]
    interactions: Vec<RawInteraction>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawInteraction {
    material: String,
    parameter: Parameter,
    offset: Option<f64>,
    slope: Option<f64>,
    exponent: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMixing {
    fluids: Vec<String>,
    diffusivity: Option<f64>,
    scheme: Option<SchemeName>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawDissolution {
    solid: String,
    into: String,
    rate: Option<f64>,
    fluid_phase: Option<u32>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawOutput {
    directory: Option<String>,
    interval: Option<f64>,
    interval_steps: Option<u64>,
    fields: Option<Vec<String>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCheckpoint {
    interval: Option<f64>,
    interval_steps: Option<u64>,
    keep: Option<u32>,
}

// ------------------------------------------------------------------------------------------
// Resolved form.
// ------------------------------------------------------------------------------------------

/// A validated scene with every default filled in.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Scene {
    /// `[simulation]`.
    pub simulation: Simulation,
    /// `[grid]`.
    pub grid: Grid,
    /// `[[materials]]`.
    pub materials: Vec<MaterialDef>,
    /// `[[bodies]]`.
    pub bodies: Vec<BodyDef>,
    /// `[[boundaries]]`.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub boundaries: Vec<BoundaryDef>,
    /// `[[couplings]]` between phase grids.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub couplings: Vec<CouplingDef>,
    /// `[porous]`, if the scene has porous interaction.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub porous: Option<PorousDef>,
    /// `[mixing]`, if two fluids mix.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mixing: Option<MixingDef>,
    /// `[dissolution]`, if a solid dissolves.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dissolution: Option<DissolutionDef>,
    /// `[output]`.
    pub output: OutputDef,
    /// `[checkpoint]`, if checkpoints are written.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub checkpoint: Option<CheckpointDef>,
    /// `[tlmpm]`: present exactly when `simulation.solver = "tlmpm"`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tlmpm: Option<TlmpmDef>,
    /// `[[fixed]]`: Dirichlet regions of the TLMPM reference grid.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub fixed: Vec<FixedDef>,
    /// `[[loads]]`: constant forces on the TLMPM particles.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub loads: Vec<LoadDef>,
}

/// `[simulation]`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Simulation {
    /// Spatial dimension, 2 or 3.
    pub dim: usize,
    /// Solver.
    pub solver: SolverKind,
    /// When the run stops.
    #[serde(flatten)]
    pub duration: Duration,
    /// Time-step control.
    #[serde(flatten)]
    pub time_step: TimeStepDef,
    /// Gravitational acceleration (m/s²).
    pub gravity: Vec<f64>,
    /// Reaction to a failed guard check.
    pub on_instability: InstabilityAction,
    /// Maximum dt/2 retries per step (with `on_instability = "retry"`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_retries: Option<u32>,
    /// Transfer scheme.
    pub transfer: TransferKind,
    /// FLIP fraction (with `transfer = "flip"`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub flip_blend: Option<f64>,
    /// Fluid volume update.
    pub volume_update: VolumeUpdateKind,
    /// Initial particle volumes.
    pub initial_volume: InitialVolume,
    /// Predictive soft walls, if enabled.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub soft_walls: Option<SoftWallsDef>,
}

/// When a run stops.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(untagged)]
pub enum Duration {
    /// At simulation time `end_time` (s).
    EndTime {
        /// End time (s).
        end_time: f64,
    },
    /// After `steps` steps.
    Steps {
        /// Step count.
        steps: u64,
    },
}

/// Time-step control.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(untagged)]
pub enum TimeStepDef {
    /// `dt = min(cfl·Δx/max(|v| + c), viscous limit, dt_max)`, failing below `dt_min`.
    Adaptive {
        /// CFL factor (dimensionless).
        cfl: f64,
        /// Largest step (s).
        dt_max: f64,
        /// Smallest step (s).
        dt_min: f64,
    },
    /// A fixed step (s).
    Fixed {
        /// The step (s).
        dt: f64,
    },
}

/// `[simulation.soft_walls]`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SoftWallsDef {
    /// Distance from each face of the grid box (m).
    pub margin: f64,
    /// Look-ahead time (s).
    pub lookahead: f64,
}

/// `[grid]`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Grid {
    /// Lower corner (m).
    pub min: Vec<f64>,
    /// Upper corner (m), rounded up to whole cells by the solver.
    pub max: Vec<f64>,
    /// Node spacing (m).
    pub dx: f64,
    /// Interpolation kernel.
    pub kernel: KernelKind,
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

/// Parameters of a Tait fluid.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct FluidDef {
    /// Rest density (kg/m^D).
    pub density: f64,
    /// Bulk modulus (Pa).
    pub bulk_modulus: f64,
    /// Tait exponent γ.
    pub gamma: f64,
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
            ModelDef::Tait(f) => Material::Fluid(FluidMaterial {
                density: f.density,
                eos: Tait {
                    bulk_modulus: f.bulk_modulus,
                    gamma: f.gamma,
                },
                viscosity: f.viscosity,
            }),
        }
    }
}

/// One `[[bodies]]` entry.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BodyDef {
    /// Name (for messages).
    pub name: String,
    /// Material name.
    pub material: String,
    /// Index of the material in `Scene::materials`.
    #[serde(skip)]
    pub material_index: usize,
    /// Phase (grid) the body lives on.
    pub phase: u32,
    /// Shape.
    #[serde(flatten)]
    pub shape: ShapeDef,
    /// Sampling.
    #[serde(flatten)]
    pub sampling: SamplingDef,
    /// Constant part of the initial velocity v₀ (m/s).
    pub velocity: Vec<f64>,
    /// Affine initial velocity gradient A (1/s): `v = v₀ + A (x − about)`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub velocity_gradient: Option<Vec<Vec<f64>>>,
    /// Rigid rotation ω (rad/s; one number in 2D, a vector in 3D): `v = v₀ + ω × (x − about)`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub angular_velocity: Option<NumberOrList>,
    /// Reference point of the affine or rotational field (m).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub about: Option<Vec<f64>>,
    /// Initial effective volume fraction φ_eff (dimensionless; with `[porous]` only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub initial_phi_eff: Option<f64>,
    /// Initial concentration α of the second mixing fluid, or initial dissolution progress of
    /// the dissolving solid (dimensionless; with `[mixing]` only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub concentration: Option<f64>,
}

/// A body shape with its parameters.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "shape", rename_all = "snake_case")]
pub enum ShapeDef {
    /// Axis-aligned box.
    Box {
        /// Lower corner (m).
        min: Vec<f64>,
        /// Upper corner (m).
        max: Vec<f64>,
    },
    /// Sphere (disk in 2D).
    Sphere {
        /// Centre (m).
        center: Vec<f64>,
        /// Radius (m).
        radius: f64,
    },
    /// Cylinder.
    Cylinder {
        /// Centre (m).
        center: Vec<f64>,
        /// Axis direction.
        axis: Vec<f64>,
        /// Radius (m).
        radius: f64,
        /// Half of the length (m).
        half_length: f64,
    },
    /// OBJ triangle mesh: `x = R (scale ⊙ x_obj) + translation`.
    Mesh {
        /// OBJ file as written in the scene (relative to the scene file).
        file: String,
        /// Per-axis scale factors.
        scale: Vec<f64>,
        /// Euler angles about x, then y, then z (degrees).
        rotation: Vec<f64>,
        /// Translation (m).
        translation: Vec<f64>,
        /// Resolved path of the OBJ file.
        #[serde(skip)]
        path: PathBuf,
    },
}

/// A sampling with its parameters.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(tag = "sampling", rename_all = "snake_case")]
pub enum SamplingDef {
    /// Regular lattice.
    Lattice {
        /// Particles per cell per axis.
        per_axis: u32,
        /// Jitter as a fraction of the particle spacing, in [0, 0.5).
        jitter: f64,
        /// Seed of the jitter.
        seed: u64,
    },
    /// Poisson-disk sampling.
    Poisson {
        /// Minimum distance between particles (m).
        poisson_radius: f64,
        /// Seed.
        seed: u64,
    },
}

/// One `[[boundaries]]` entry.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BoundaryDef {
    /// Kind and geometry.
    #[serde(flatten)]
    pub geometry: BoundaryGeometry,
    /// Contact rule.
    pub contact: ContactName,
    /// Coulomb friction coefficient.
    pub friction: f64,
    /// Translation velocity of a collider (m/s); walls do not move.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub velocity: Option<Vec<f64>>,
}

/// Boundary kinds with their geometry.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum BoundaryGeometry {
    /// Walls of the grid box.
    Walls {
        /// Node layers per face.
        thickness: u32,
    },
    /// Half-space `(x − point)·normal ≤ 0`.
    HalfSpace {
        /// A point on the plane (m).
        point: Vec<f64>,
        /// Normal pointing out of the collider, into the material.
        normal: Vec<f64>,
    },
    /// Solid box.
    Box {
        /// Lower corner (m).
        min: Vec<f64>,
        /// Upper corner (m).
        max: Vec<f64>,
    },
    /// Solid sphere.
    Sphere {
        /// Centre (m).
        center: Vec<f64>,
        /// Radius (m).
        radius: f64,
    },
}

/// One `[[couplings]]` entry: how the grids of two phases exchange momentum.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CouplingDef {
    /// The two phases `[a, b]`; for permeability drag and pore-pressure buoyancy, `b` is the
    /// fluid.
    pub phases: [u32; 2],
    /// Kind and parameters.
    #[serde(flatten)]
    pub kind: CouplingKindDef,
    /// Buoyancy penalty strength c_b (dimensionless; Eq. 32), if any.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub buoyancy: Option<f64>,
    /// The pore-pressure buoyancy term of Eq. 15 (unstable in many set-ups).
    pub pressure_buoyancy: bool,
}

/// Coupling kinds with their parameters.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum CouplingKindDef {
    /// Single-grid coupling.
    Full,
    /// Drag (Eq. 14), clamped to full coupling (Eq. 17).
    Drag(DragDef),
    /// Contact (Eqs. 24–30).
    Contact(ContactDef),
}

/// The drag coefficient c_E of Eq. 14.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(untagged)]
pub enum DragDef {
    /// Given directly.
    Coefficient {
        /// c_E (1/(kg·s)).
        coefficient: f64,
    },
    /// From porosity and hydraulic conductivity (Tampubolon et al. 2017).
    Permeability {
        /// Porosity n ∈ (0, 1].
        porosity: f64,
        /// Hydraulic conductivity k (m/s).
        conductivity: f64,
    },
}

/// Parameters of a contact coupling.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ContactDef {
    /// Normal share β ∈ [0, 1].
    pub normal_share: f64,
    /// Friction δ ≥ 0.
    pub friction: f64,
    /// Tangential force rule.
    pub friction_model: FrictionModel,
    /// When the force applies.
    pub apply: ApplyName,
}

/// `[porous]`: the effective volume fraction and the parameters it scales.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PorousDef {
    /// Update rule of φ_eff.
    #[serde(flatten)]
    pub phi_eff: PhiEffDef,
    /// Initial φ_eff of bodies that do not set their own (dimensionless).
    pub initial_phi_eff: f64,
    /// `[[porous.interactions]]`.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub interactions: Vec<InteractionDef>,
}

/// Update rules of φ_eff with their parameters.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(tag = "phi_eff", rename_all = "snake_case")]
pub enum PhiEffDef {
    /// φ_eff = φ.
    Current,
    /// Eq. 21.
    Max,
    /// Eq. 22.
    Relax {
        /// Relaxation rate (1/s); α = min(1, rate·dt).
        rate: f64,
    },
    /// Eq. 36.
    MaxRelax {
        /// Relaxation rate (1/s); α = min(1, rate·dt).
        rate: f64,
    },
}

/// One `[[porous.interactions]]` entry: `parameter` of `material` is multiplied by
/// `max(0, offset + slope·φ_eff^exponent)`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct InteractionDef {
    /// Material name.
    pub material: String,
    /// Index of the material in `Scene::materials`.
    #[serde(skip)]
    pub material_index: usize,
    /// The scaled parameter.
    pub parameter: Parameter,
    /// Factor at φ_eff = 0 (dimensionless).
    pub offset: f64,
    /// Change of the factor between φ_eff = 0 and 1 (dimensionless).
    pub slope: f64,
    /// Exponent of φ_eff (dimensionless, > 0).
    pub exponent: f64,
}

/// `[mixing]`: two miscible fluids of one phase.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MixingDef {
    /// The two fluid material names; the concentration α is the fraction of the second.
    pub fluids: [String; 2],
    /// Their indices in `Scene::materials`.
    #[serde(skip)]
    pub fluid_indices: [usize; 2],
    /// Diffusion coefficient k_d (m²/s).
    pub diffusivity: f64,
    /// Discretisation of the Laplacian.
    pub scheme: SchemeName,
}

/// `[dissolution]`: a solid dissolving into the second mixing fluid.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DissolutionDef {
    /// The dissolving solid material.
    pub solid: String,
    /// Its index in `Scene::materials`.
    #[serde(skip)]
    pub solid_index: usize,
    /// The fluid material it becomes (the second mixing fluid).
    pub into: String,
    /// Its index in `Scene::materials`.
    #[serde(skip)]
    pub into_index: usize,
    /// Dissolution rate (1/s).
    pub rate: f64,
    /// The phase of the solvent fluid.
    pub fluid_phase: u32,
}

/// An output or checkpoint interval.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(untagged)]
pub enum Interval {
    /// Every `interval` seconds of simulation time.
    Time {
        /// Interval (s).
        interval: f64,
    },
    /// Every `interval_steps` steps.
    Steps {
        /// Interval (steps).
        interval_steps: u64,
    },
}

/// `[output]`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct OutputDef {
    /// Output directory (relative to the working directory).
    pub directory: String,
    /// Snapshot interval.
    #[serde(flatten)]
    pub interval: Interval,
    /// Fields written to snapshots.
    pub fields: Vec<String>,
}

/// `[checkpoint]`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct CheckpointDef {
    /// Checkpoint interval.
    #[serde(flatten)]
    pub interval: Interval,
    /// How many of the newest checkpoints are kept.
    pub keep: u32,
}

/// A scene read from a file: the resolved scene plus what is needed to report problems found
/// later (while building) at their place in the file.
#[derive(Clone, Debug)]
pub struct LoadedScene {
    /// The resolved scene.
    pub scene: Scene,
    /// The scene file.
    pub path: PathBuf,
    /// Its text.
    pub text: String,
    /// Key spans.
    pub spans: SpanIndex,
}

impl LoadedScene {
    /// A diagnostic about `key`, located at the key (or its enclosing table).
    pub fn diag(&self, key: &str, message: impl Into<String>) -> Diagnostic {
        Diagnostic {
            key: Some(key.to_string()),
            span: self.spans.locate(key),
            message: message.into(),
        }
    }

    /// A scene error with one diagnostic about `key`.
    pub fn error(&self, key: &str, message: impl Into<String>) -> SceneError {
        SceneError::new(&self.path, &self.text, vec![self.diag(key, message)])
    }

    /// The `mpm-core` material table.
    pub fn materials(&self) -> Vec<Material> {
        self.scene
            .materials
            .iter()
            .map(|m| m.model.material())
            .collect()
    }

    /// The particle columns this scene needs.
    pub fn columns(&self) -> Columns {
        self.scene.columns()
    }
}

/// Reads and resolves the scene file at `path`. A missing or unreadable file and every problem
/// in it are bad input (exit code 2).
pub fn load(path: &Path) -> Result<LoadedScene, CliError> {
    let text = std::fs::read_to_string(path).map_err(|e| {
        CliError::BadInput(format!(
            "error: cannot read scene file {}: {e}",
            path.display()
        ))
    })?;
    parse(path, &text).map_err(CliError::from)
}

/// Parses and resolves scene `text` read from `path` (relative mesh paths are resolved against
/// `path`'s directory).
pub fn parse(path: &Path, text: &str) -> Result<LoadedScene, SceneError> {
    let spans = SpanIndex::new(text);
    let raw: RawScene = toml::from_str(text)
        .map_err(|e| SceneError::new(path, text, vec![parser_diagnostic(&spans, &e, text)]))?;
    let mut c = Checker {
        spans: &spans,
        items: Vec::new(),
    };
    let scene = resolve(&mut c, raw, path);
    match scene {
        Some(scene) if c.items.is_empty() => Ok(LoadedScene {
            scene,
            path: path.to_path_buf(),
            text: text.to_string(),
            spans,
        }),
        _ => {
            let mut items = c.items;
            items.sort_by_key(|d| d.span.as_ref().map_or(usize::MAX, |s| s.start));
            Err(SceneError::new(path, text, items))
        }
    }
}

/// Turns a TOML/serde error into a diagnostic naming the key at its span.
fn parser_diagnostic(spans: &SpanIndex, e: &toml::de::Error, text: &str) -> Diagnostic {
    let message = e.message().trim().to_string();
    let span = e.span();
    let mut key = span.as_ref().and_then(|s| spans.path_at(s));
    // "missing field `x`" points at the enclosing table: name the missing key itself.
    if let Some(field) = message
        .strip_prefix("missing field `")
        .and_then(|m| m.split('`').next())
    {
        key = Some(match key {
            Some(parent)
                if span
                    .as_ref()
                    .is_some_and(|s| s.end > s.start && s.end <= text.len()) =>
            {
                format!("{parent}.{field}")
            }
            _ => field.to_string(),
        });
    }
    Diagnostic { key, span, message }
}

// ------------------------------------------------------------------------------------------
// Validation and resolution.
// ------------------------------------------------------------------------------------------

struct Checker<'a> {
    spans: &'a SpanIndex,
    items: Vec<Diagnostic>,
}

impl Checker<'_> {
    fn err(&mut self, key: &str, message: impl Into<String>) {
        self.items.push(Diagnostic {
            key: Some(key.to_string()),
            span: self.spans.locate(key),
            message: message.into(),
        });
    }

    /// A finite number satisfying `ok`, else an error `what`.
    fn num(&mut self, key: &str, v: f64, ok: impl Fn(f64) -> bool, what: &str) -> f64 {
        if !(v.is_finite() && ok(v)) {
            self.err(key, format!("{} (got {v})", what));
        }
        v
    }

    fn positive(&mut self, key: &str, v: f64) -> f64 {
        self.num(key, v, |x| x > 0.0, "must be a positive finite number")
    }

    fn non_negative(&mut self, key: &str, v: f64) -> f64 {
        self.num(key, v, |x| x >= 0.0, "must be a finite number ≥ 0")
    }

    /// A vector of `d` finite numbers.
    fn vector(&mut self, key: &str, v: &[f64], d: usize) -> Vec<f64> {
        if v.len() != d {
            self.err(
                key,
                format!("must have {d} components (dim = {d}), got {}", v.len()),
            );
        } else if let Some((i, x)) = v.iter().enumerate().find(|(_, x)| !x.is_finite()) {
            self.err(&format!("{key}[{i}]"), format!("must be finite (got {x})"));
        }
        v.to_vec()
    }

    /// A required key.
    fn required<T: Clone>(&mut self, key: &str, v: &Option<T>, why: &str) -> Option<T> {
        if v.is_none() {
            self.err(key, format!("missing key: {why}"));
        }
        v.clone()
    }

    /// Rejects `key` when it is present (`present`) but does not apply.
    fn not_applicable(&mut self, key: &str, present: bool, why: &str) {
        if present {
            self.err(key, format!("does not apply {why}"));
        }
    }
}

/// Largest number of grid nodes a scene may ask for (memory guard against typos).
pub const MAX_GRID_NODES: f64 = 64e6;

fn resolve(c: &mut Checker<'_>, raw: RawScene, path: &Path) -> Option<Scene> {
    let sim = resolve_simulation(c, &raw.simulation)?;
    let d = sim.dim;
    let grid = resolve_grid(c, &raw.grid, d);
    let materials: Vec<MaterialDef> = raw
        .materials
        .iter()
        .enumerate()
        .map(|(i, m)| resolve_material(c, i, m, d))
        .collect();
    if materials.is_empty() {
        c.err(
            "materials",
            "a scene needs at least one [[materials]] entry",
        );
    }
    for (i, m) in materials.iter().enumerate() {
        if materials[..i].iter().any(|o| o.name == m.name) {
            c.err(
                &format!("materials[{i}].name"),
                format!("duplicate material name \"{}\"", m.name),
            );
        }
    }
    let base = path.parent().unwrap_or(Path::new("."));
    let mut bodies: Vec<BodyDef> = raw
        .bodies
        .iter()
        .enumerate()
        .filter_map(|(i, b)| resolve_body(c, i, b, d, &materials, base))
        .collect();
    if raw.bodies.is_empty() {
        c.err("bodies", "a scene needs at least one [[bodies]] entry");
    }
    for (i, b) in bodies.iter().enumerate() {
        if bodies[..i].iter().any(|o| o.name == b.name) {
            c.err(
                &format!("bodies[{i}].name"),
                format!("duplicate body name \"{}\"", b.name),
            );
        }
    }
    let boundaries: Vec<BoundaryDef> = raw
        .boundaries
        .iter()
        .enumerate()
        .filter_map(|(i, b)| resolve_boundary(c, i, b, d))
        .collect();
    let walls = boundaries
        .iter()
        .enumerate()
        .filter(|(_, b)| matches!(b.geometry, BoundaryGeometry::Walls { .. }))
        .map(|(i, _)| i)
        .collect::<Vec<_>>();
    if let Some(&second) = walls.get(1) {
        c.err(
            &format!("boundaries[{second}].type"),
            "the domain walls are given twice",
        );
    }
    let core: Vec<Material> = materials.iter().map(|m| m.model.material()).collect();
    let phases = phase_count(&bodies);
    check_phases(c, &bodies, phases, &grid);
    let couplings = resolve_couplings(c, &raw.couplings, &bodies, &core, phases);
    let porous = raw
        .porous
        .as_ref()
        .map(|p| resolve_porous(c, p, &materials, &core, phases));
    let mixing = raw
        .mixing
        .as_ref()
        .map(|m| resolve_mixing(c, m, &materials, &bodies, grid.kernel));
    let dissolution = raw
        .dissolution
        .as_ref()
        .map(|x| resolve_dissolution(c, x, &materials, mixing.as_ref(), &bodies, phases));
    resolve_body_state(
        c,
        &raw.bodies,
        &mut bodies,
        porous.as_ref(),
        mixing.as_ref(),
        dissolution.as_ref(),
    );
    let columns = columns_for(
        &core,
        phases,
        porous.is_some(),
        mixing.is_some() || dissolution.is_some(),
    );
    let has_fluid = core.iter().any(|m| matches!(m, Material::Fluid(_)));
    let stem = path
        .file_stem()
        .map_or("scene".into(), |s| s.to_string_lossy().into_owned());
    let output = resolve_output(
        c,
        raw.output.as_ref(),
        &sim.duration,
        &columns,
        has_fluid,
        &stem,
    );
    let checkpoint = raw.checkpoint.as_ref().map(|ck| resolve_checkpoint(c, ck));
    let tl = tlmpm::resolve(c, &raw, &sim, (grid.dx, &materials), &boundaries);
    Some(Scene {
        simulation: sim,
        grid,
        materials,
        bodies,
        boundaries,
        couplings,
        porous,
        mixing,
        dissolution,
        output,
        checkpoint,
        tlmpm: tl.tlmpm,
        fixed: tl.fixed,
        loads: tl.loads,
    })
}

/// Largest number of phases (grids) a scene may have.
pub const MAX_PHASES: u32 = 16;

/// Number of phases of `bodies`: one more than the largest phase.
fn phase_count(bodies: &[BodyDef]) -> u32 {
    bodies
        .iter()
        .map(|b| b.phase)
        .max()
        .map_or(1, |k| k.saturating_add(1))
}

/// The particle columns of a scene with `materials`, `phases` phases, and porous interaction
/// and concentrations when `porous` and `concentration`.
fn columns_for(materials: &[Material], phases: u32, porous: bool, concentration: bool) -> Columns {
    Columns {
        phase: phases > 1,
        volume_fraction: porous,
        concentration,
        ..Columns::for_materials(materials)
    }
}

/// Phases are numbered 0, 1, … without gaps, and all their grids fit in memory.
fn check_phases(c: &mut Checker<'_>, bodies: &[BodyDef], phases: u32, grid: &Grid) {
    for k in 0..phases {
        if !bodies.iter().any(|b| b.phase == k) {
            if let Some(i) = bodies.iter().position(|b| b.phase > k) {
                c.err(
                    &format!("bodies[{i}].phase"),
                    format!("phases are numbered from 0 without gaps, but no body is in phase {k}"),
                );
            }
            break;
        }
    }
    if phases > 1 && grid.min.len() == grid.max.len() && grid.dx > 0.0 {
        let nodes: f64 = grid
            .min
            .iter()
            .zip(&grid.max)
            .map(|(lo, hi)| ((hi - lo) / grid.dx).abs().ceil() + 1.0)
            .product();
        let total = nodes * phases as f64;
        if total > MAX_GRID_NODES {
            c.err(
                "grid.dx",
                format!(
                    "{phases} phase grids would have {total:.3e} nodes in all (limit \
                     {MAX_GRID_NODES:.0e}): increase dx or shrink the domain"
                ),
            );
        }
    }
}

/// The index of material `name`, or an error at `key` listing the materials.
fn material_index(
    c: &mut Checker<'_>,
    key: &str,
    name: &str,
    materials: &[MaterialDef],
) -> Option<usize> {
    let found = materials.iter().position(|m| m.name == name);
    if found.is_none() {
        let names: Vec<_> = materials
            .iter()
            .map(|m| format!("\"{}\"", m.name))
            .collect();
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
    found
}

fn is_fluid(m: &MaterialDef) -> bool {
    matches!(m.model, ModelDef::Tait(_))
}

fn resolve_couplings(
    c: &mut Checker<'_>,
    raw: &[RawCoupling],
    bodies: &[BodyDef],
    materials: &[Material],
    phases: u32,
) -> Vec<CouplingDef> {
    let out: Vec<CouplingDef> = raw
        .iter()
        .enumerate()
        .map(|(i, r)| resolve_coupling(c, i, r, bodies, materials, phases))
        .collect();
    for (i, a) in out.iter().enumerate() {
        let pair = |x: &CouplingDef| {
            let [p, q] = x.phases;
            (p.min(q), p.max(q))
        };
        if let Some(j) = out[..i].iter().position(|b| pair(b) == pair(a)) {
            c.err(
                &format!("couplings[{i}].phases"),
                format!(
                    "phases {} and {} are already coupled by couplings[{j}]",
                    a.phases[0], a.phases[1]
                ),
            );
        }
    }
    out
}

fn resolve_coupling(
    c: &mut Checker<'_>,
    i: usize,
    r: &RawCoupling,
    bodies: &[BodyDef],
    materials: &[Material],
    phases: u32,
) -> CouplingDef {
    let k = |name: &str| format!("couplings[{i}].{name}");
    let pair = match r.phases.as_slice() {
        &[a, b] => {
            if a == b {
                c.err(
                    &k("phases"),
                    format!("the two phases must differ (got [{a}, {b}])"),
                );
            }
            for (j, p) in [a, b].into_iter().enumerate() {
                if p >= phases {
                    c.err(
                        &k(&format!("phases[{j}]")),
                        format!(
                            "no body is in phase {p} (the bodies' phases are 0..={})",
                            phases - 1
                        ),
                    );
                }
            }
            Some([a, b])
        }
        other => {
            c.err(
                &k("phases"),
                format!(
                    "must be two phase numbers [a, b], got {} number(s)",
                    other.len()
                ),
            );
            None
        }
    };
    let kind_name = serde_plain(&r.kind);
    let present = [
        ("coefficient", r.coefficient.is_some()),
        ("porosity", r.porosity.is_some()),
        ("conductivity", r.conductivity.is_some()),
        ("normal_share", r.normal_share.is_some()),
        ("friction", r.friction.is_some()),
        ("friction_model", r.friction_model.is_some()),
        ("apply", r.apply.is_some()),
    ];
    let used: &[&str] = match r.kind {
        CouplingName::Full => &[],
        CouplingName::Drag => &["coefficient", "porosity", "conductivity"],
        CouplingName::Contact => &["normal_share", "friction", "friction_model", "apply"],
    };
    for (key, p) in present {
        if !used.contains(&key) {
            c.not_applicable(&k(key), p, &format!("to kind = \"{kind_name}\""));
        }
    }
    // Phase b of a permeability drag or of pore-pressure buoyancy is the fluid.
    let fluid_b = |c: &mut Checker<'_>, key: &str, what: &str| {
        let Some([_, b]) = pair else { return };
        let solid = bodies.iter().find(|body| {
            body.phase == b
                && !matches!(materials.get(body.material_index), Some(Material::Fluid(_)))
        });
        if let Some(body) = solid {
            c.err(
                key,
                format!(
                    "{what} takes phase b = {b} as the fluid, but body \"{}\" in phase {b} is \
                     of the solid \"{}\" (write the fluid's phase second in `phases`)",
                    body.name, body.material
                ),
            );
        }
    };
    let kind = match r.kind {
        CouplingName::Full => CouplingKindDef::Full,
        CouplingName::Drag => {
            let drag = match (r.coefficient, r.porosity, r.conductivity) {
                (Some(ce), None, None) => DragDef::Coefficient {
                    coefficient: c.non_negative(&k("coefficient"), ce),
                },
                (None, Some(n), Some(cond)) => {
                    let porosity = c.num(
                        &k("porosity"),
                        n,
                        |x| x > 0.0 && x <= 1.0,
                        "must lie in (0, 1]",
                    );
                    let conductivity = c.positive(&k("conductivity"), cond);
                    fluid_b(c, &k("phases"), "permeability drag");
                    DragDef::Permeability {
                        porosity,
                        conductivity,
                    }
                }
                (Some(_), _, _) => {
                    c.err(
                        &k("coefficient"),
                        "give either `coefficient` or `porosity` and `conductivity`, not both",
                    );
                    DragDef::Coefficient { coefficient: 0.0 }
                }
                (None, None, None) => {
                    c.err(
                        &k("kind"),
                        "missing key: kind = \"drag\" needs `coefficient` (1/(kg·s)), or \
                         `porosity` and `conductivity` (m/s)",
                    );
                    DragDef::Coefficient { coefficient: 0.0 }
                }
                (None, Some(_), None) => {
                    c.err(
                        &k("conductivity"),
                        "missing key: `porosity` goes with `conductivity` (m/s)",
                    );
                    DragDef::Coefficient { coefficient: 0.0 }
                }
                (None, None, Some(_)) => {
                    c.err(
                        &k("porosity"),
                        "missing key: `conductivity` goes with `porosity` (0, 1]",
                    );
                    DragDef::Coefficient { coefficient: 0.0 }
                }
            };
            CouplingKindDef::Drag(drag)
        }
        CouplingName::Contact => CouplingKindDef::Contact(ContactDef {
            normal_share: c.num(
                &k("normal_share"),
                r.normal_share.unwrap_or(1.0),
                |x| (0.0..=1.0).contains(&x),
                "must lie in [0, 1]",
            ),
            friction: c.non_negative(&k("friction"), r.friction.unwrap_or(0.0)),
            friction_model: r.friction_model.unwrap_or(FrictionModel::Coulomb),
            apply: r.apply.unwrap_or(ApplyName::OnApproach),
        }),
    };
    let pressure_buoyancy = r.pressure_buoyancy.unwrap_or(false);
    if pressure_buoyancy {
        fluid_b(
            c,
            &k("pressure_buoyancy"),
            "pore-pressure buoyancy (Eq. 15)",
        );
    }
    CouplingDef {
        phases: pair.unwrap_or([0, 1]),
        kind,
        buoyancy: r.buoyancy.map(|b| c.non_negative(&k("buoyancy"), b)),
        pressure_buoyancy,
    }
}

/// Every parameter a porous interaction can scale.
const PARAMETERS: [Parameter; 8] = [
    Parameter::YoungsModulus,
    Parameter::Cohesion,
    Parameter::FrictionAngle,
    Parameter::CriticalCompression,
    Parameter::CriticalStretch,
    Parameter::Hardening,
    Parameter::Viscosity,
    Parameter::BulkModulus,
];

fn resolve_porous(
    c: &mut Checker<'_>,
    p: &RawPorous,
    materials: &[MaterialDef],
    core: &[Material],
    phases: u32,
) -> PorousDef {
    if phases < 2 {
        c.err(
            "porous",
            "porous interaction needs at least two phases: put the fluid's bodies in another \
             phase (`phase = 1`) and couple them",
        );
    }
    let rule = p.phi_eff.unwrap_or(PhiEffRule::Current);
    let rate = |c: &mut Checker<'_>| c.non_negative("porous.rate", p.rate.unwrap_or(1.0));
    let phi_eff = match rule {
        PhiEffRule::Current | PhiEffRule::Max => {
            c.not_applicable(
                "porous.rate",
                p.rate.is_some(),
                &format!("to phi_eff = \"{}\"", serde_plain(&rule)),
            );
            if rule == PhiEffRule::Current {
                PhiEffDef::Current
            } else {
                PhiEffDef::Max
            }
        }
        PhiEffRule::Relax => PhiEffDef::Relax { rate: rate(c) },
        PhiEffRule::MaxRelax => PhiEffDef::MaxRelax { rate: rate(c) },
    };
    let initial_phi_eff = c.num(
        "porous.initial_phi_eff",
        p.initial_phi_eff.unwrap_or(0.0),
        |x| (0.0..=1.0).contains(&x),
        "must lie in [0, 1]",
    );
    let interactions = p
        .interactions
        .iter()
        .enumerate()
        .map(|(j, it)| {
            let k = |name: &str| format!("porous.interactions[{j}].{name}");
            let index = material_index(c, &k("material"), &it.material, materials);
            if let Some(m) = index.and_then(|i| core.get(i)) {
                if !it.parameter.applies_to(m) {
                    let has: Vec<String> = PARAMETERS
                        .iter()
                        .filter(|q| q.applies_to(m))
                        .map(|q| format!("\"{}\"", serde_plain(q)))
                        .collect();
                    c.err(
                        &k("parameter"),
                        format!(
                            "material \"{}\" has no parameter \"{}\" (it has: {})",
                            it.material,
                            serde_plain(&it.parameter),
                            has.join(", ")
                        ),
                    );
                }
            }
            let finite = |c: &mut Checker<'_>, key: &str, v: f64| {
                c.num(key, v, |_| true, "must be a finite number")
            };
            let slope = match it.slope {
                Some(s) => finite(c, &k("slope"), s),
                None => {
                    c.err(
                        &k("slope"),
                        "missing key: the factor is offset + slope·phi_eff^exponent",
                    );
                    0.0
                }
            };
            InteractionDef {
                material: it.material.clone(),
                material_index: index.unwrap_or(0),
                parameter: it.parameter,
                offset: finite(c, &k("offset"), it.offset.unwrap_or(1.0)),
                slope,
                exponent: c.positive(&k("exponent"), it.exponent.unwrap_or(1.0)),
            }
        })
        .collect();
    PorousDef {
        phi_eff,
        initial_phi_eff,
        interactions,
    }
}

fn resolve_mixing(
    c: &mut Checker<'_>,
    m: &RawMixing,
    materials: &[MaterialDef],
    bodies: &[BodyDef],
    kernel: KernelKind,
) -> MixingDef {
    let mut names = [String::new(), String::new()];
    let mut indices = [0, 0];
    if m.fluids.len() == 2 {
        for j in 0..2 {
            let key = format!("mixing.fluids[{j}]");
            if let Some(i) = material_index(c, &key, &m.fluids[j], materials) {
                if !is_fluid(&materials[i]) {
                    c.err(
                        &key,
                        format!(
                            "material \"{}\" is a solid: mixing needs two fluids \
                             (model = \"tait\")",
                            m.fluids[j]
                        ),
                    );
                }
                indices[j] = i;
            }
            names[j] = m.fluids[j].clone();
        }
        if names[0] == names[1] {
            c.err("mixing.fluids", "the two fluids must differ");
        }
    } else {
        c.err(
            "mixing.fluids",
            format!(
                "must name two fluid materials [\"a\", \"b\"], got {}",
                m.fluids.len()
            ),
        );
    }
    let diffusivity = match m.diffusivity {
        Some(k) => c.non_negative("mixing.diffusivity", k),
        None => {
            c.err(
                "mixing.diffusivity",
                "missing key: diffusivity k_d (m²/s) is required (0 blends properties \
                 without diffusion)",
            );
            0.0
        }
    };
    let scheme = m.scheme.unwrap_or(SchemeName::KernelGradient);
    if scheme == SchemeName::MlsDifference && kernel == KernelKind::Linear {
        c.err(
            "mixing.scheme",
            "scheme = \"mls_difference\" needs a quadratic or cubic kernel (grid.kernel)",
        );
    }
    let mut fluid_bodies = bodies
        .iter()
        .enumerate()
        .filter(|(_, b)| names.contains(&b.material));
    if let Some((_, first)) = fluid_bodies.next() {
        if let Some((i, other)) = fluid_bodies.find(|(_, b)| b.phase != first.phase) {
            c.err(
                &format!("bodies[{i}].phase"),
                format!(
                    "the bodies of the mixing fluids must be in one phase: body \"{}\" is in \
                     phase {}, body \"{}\" in phase {}",
                    other.name, other.phase, first.name, first.phase
                ),
            );
        }
    }
    MixingDef {
        fluids: names,
        fluid_indices: indices,
        diffusivity,
        scheme,
    }
}

fn resolve_dissolution(
    c: &mut Checker<'_>,
    d: &RawDissolution,
    materials: &[MaterialDef],
    mixing: Option<&MixingDef>,
    bodies: &[BodyDef],
    phases: u32,
) -> DissolutionDef {
    let solid_index = material_index(c, "dissolution.solid", &d.solid, materials);
    if let Some(i) = solid_index {
        if is_fluid(&materials[i]) {
            c.err(
                "dissolution.solid",
                format!(
                    "material \"{}\" is a fluid: only a solid dissolves",
                    d.solid
                ),
            );
        }
    }
    let into_index = material_index(c, "dissolution.into", &d.into, materials);
    let mut fluid_bodies = bodies.iter().filter(|b| match mixing {
        Some(m) => m.fluids.contains(&b.material),
        None => false,
    });
    let derived = fluid_bodies.next().map(|b| b.phase);
    match mixing {
        None => c.err(
            "dissolution",
            "dissolution needs a [mixing] table with fluids = [\"<solvent>\", \"<into>\"]: the \
             dissolved material mixes into the solvent as its second fluid",
        ),
        Some(m) if into_index.is_some() && m.fluids[1] != d.into => c.err(
            "dissolution.into",
            format!(
                "must be the second fluid of [mixing] (\"{}\"), got \"{}\"",
                m.fluids[1], d.into
            ),
        ),
        Some(_) => {}
    }
    let rate = match d.rate {
        Some(r) => c.non_negative("dissolution.rate", r),
        None => {
            c.err(
                "dissolution.rate",
                "missing key: rate (1/s) is required: full contact with fresh fluid dissolves a \
                 particle in 1/rate seconds",
            );
            0.0
        }
    };
    let fluid_phase = match (d.fluid_phase, derived) {
        (Some(g), Some(from_bodies)) if g != from_bodies => {
            c.err(
                "dissolution.fluid_phase",
                format!("the bodies of the mixing fluids are in phase {from_bodies}, not {g}"),
            );
            g
        }
        (Some(g), _) => {
            if g >= phases {
                c.err(
                    "dissolution.fluid_phase",
                    format!(
                        "no body is in phase {g} (the bodies' phases are 0..={})",
                        phases - 1
                    ),
                );
            }
            g
        }
        (None, Some(from_bodies)) => from_bodies,
        (None, None) => {
            if mixing.is_some() {
                c.err(
                    "dissolution.fluid_phase",
                    "missing key: no body of the mixing fluids exists to take the fluid phase from",
                );
            }
            0
        }
    };
    if let Some((i, b)) = bodies
        .iter()
        .enumerate()
        .find(|(_, b)| b.material == d.solid && b.phase == fluid_phase)
    {
        c.err(
            &format!("bodies[{i}].phase"),
            format!(
                "body \"{}\" of the dissolving solid is in the fluid phase {fluid_phase}: the \
                 solid needs a phase of its own (coupled to the fluid's)",
                b.name
            ),
        );
    }
    DissolutionDef {
        solid: d.solid.clone(),
        solid_index: solid_index.unwrap_or(0),
        into: d.into.clone(),
        into_index: into_index.unwrap_or(0),
        rate,
        fluid_phase,
    }
}

/// The initial φ_eff and concentration of every body, where those columns exist.
fn resolve_body_state(
    c: &mut Checker<'_>,
    raw: &[RawBody],
    bodies: &mut [BodyDef],
    porous: Option<&PorousDef>,
    mixing: Option<&MixingDef>,
    dissolution: Option<&DissolutionDef>,
) {
    for (i, (r, b)) in raw.iter().zip(bodies.iter_mut()).enumerate() {
        let k = |name: &str| format!("bodies[{i}].{name}");
        b.initial_phi_eff = match porous {
            Some(p) => Some(c.num(
                &k("initial_phi_eff"),
                r.initial_phi_eff.unwrap_or(p.initial_phi_eff),
                |x| (0.0..=1.0).contains(&x),
                "must lie in [0, 1]",
            )),
            None => {
                c.not_applicable(
                    &k("initial_phi_eff"),
                    r.initial_phi_eff.is_some(),
                    "without a [porous] table",
                );
                None
            }
        };
        b.concentration = match mixing {
            Some(m) => {
                let carrier = m.fluids.contains(&b.material)
                    || dissolution.is_some_and(|x| x.solid == b.material);
                if !carrier {
                    c.not_applicable(
                        &k("concentration"),
                        r.concentration.is_some(),
                        &format!(
                            "to material \"{}\": only to the mixing fluids and the dissolving \
                             solid",
                            b.material
                        ),
                    );
                    None
                } else {
                    let default = if b.material == m.fluids[1] { 1.0 } else { 0.0 };
                    Some(c.num(
                        &k("concentration"),
                        r.concentration.unwrap_or(default),
                        |x| (0.0..=1.0).contains(&x),
                        "must lie in [0, 1]",
                    ))
                }
            }
            None => {
                c.not_applicable(
                    &k("concentration"),
                    r.concentration.is_some(),
                    "without a [mixing] table",
                );
                None
            }
        };
    }
}

fn resolve_simulation(c: &mut Checker<'_>, s: &RawSimulation) -> Option<Simulation> {
    let dim = match s.dim {
        2 | 3 => s.dim as usize,
        other => {
            c.err("simulation.dim", format!("must be 2 or 3 (got {other})"));
            return None;
        }
    };
    let solver = s.solver.unwrap_or(SolverKind::Explicit);
    match solver {
        SolverKind::Explicit | SolverKind::Tlmpm => {}
        SolverKind::Diq => c.err(
            "simulation.solver",
            "solver \"diq\" is not available yet (\"explicit\" and \"tlmpm\" are)",
        ),
    }
    let duration = match (s.end_time, s.steps) {
        (Some(t), None) => Duration::EndTime {
            end_time: c.positive("simulation.end_time", t),
        },
        (None, Some(n)) => {
            if n == 0 {
                c.err("simulation.steps", "must be at least 1");
            }
            Duration::Steps { steps: n }
        }
        (Some(_), Some(_)) => {
            c.err(
                "simulation.steps",
                "give either `end_time` or `steps`, not both",
            );
            Duration::Steps { steps: 1 }
        }
        (None, None) => {
            c.err(
                "simulation.end_time",
                "missing key: give `end_time` (s) or `steps`",
            );
            Duration::Steps { steps: 1 }
        }
    };
    let time_step = match s.dt {
        Some(dt) => {
            for (k, present) in [
                ("cfl", s.cfl.is_some()),
                ("dt_max", s.dt_max.is_some()),
                ("dt_min", s.dt_min.is_some()),
            ] {
                c.not_applicable(
                    &format!("simulation.{k}"),
                    present,
                    "with a fixed `dt` (remove one of them)",
                );
            }
            TimeStepDef::Fixed {
                dt: c.positive("simulation.dt", dt),
            }
        }
        None => {
            let cfl = c.num(
                "simulation.cfl",
                s.cfl.unwrap_or(0.4),
                |x| x > 0.0 && x <= 1.0,
                "must lie in (0, 1]",
            );
            let dt_max = c.positive("simulation.dt_max", s.dt_max.unwrap_or(1e-3));
            let dt_min = c.non_negative("simulation.dt_min", s.dt_min.unwrap_or(1e-12));
            if dt_min > dt_max {
                c.err("simulation.dt_min", "must not exceed dt_max");
            }
            TimeStepDef::Adaptive {
                cfl,
                dt_max,
                dt_min,
            }
        }
    };
    let gravity = match &s.gravity {
        Some(g) => c.vector("simulation.gravity", g, dim),
        None => {
            let mut g = vec![0.0; dim];
            g[1] = -9.81;
            g
        }
    };
    let on_instability = s.on_instability.unwrap_or(InstabilityAction::Abort);
    let max_retries = match on_instability {
        InstabilityAction::Abort => {
            c.not_applicable(
                "simulation.max_retries",
                s.max_retries.is_some(),
                "unless on_instability = \"retry\"",
            );
            None
        }
        InstabilityAction::Retry => {
            let n = s.max_retries.unwrap_or(4);
            if n > 30 {
                c.err("simulation.max_retries", format!("must be ≤ 30 (got {n})"));
            }
            Some(n)
        }
    };
    let transfer = s.transfer.unwrap_or(TransferKind::Apic);
    let flip_blend = if transfer == TransferKind::Flip {
        Some(c.num(
            "simulation.flip_blend",
            s.flip_blend.unwrap_or(0.95),
            |x| (0.0..=1.0).contains(&x),
            "must lie in [0, 1]",
        ))
    } else {
        c.not_applicable(
            "simulation.flip_blend",
            s.flip_blend.is_some(),
            "unless transfer = \"flip\"",
        );
        None
    };
    let soft_walls = s.soft_walls.as_ref().map(|w| SoftWallsDef {
        margin: c.non_negative("simulation.soft_walls.margin", w.margin),
        lookahead: c.positive("simulation.soft_walls.lookahead", w.lookahead),
    });
    Some(Simulation {
        dim,
        solver,
        duration,
        time_step,
        gravity,
        on_instability,
        max_retries,
        transfer,
        flip_blend,
        volume_update: s.volume_update.unwrap_or(VolumeUpdateKind::Deformation),
        initial_volume: s.initial_volume.unwrap_or(InitialVolume::Sampling),
        soft_walls,
    })
}

fn resolve_grid(c: &mut Checker<'_>, g: &RawGrid, d: usize) -> Grid {
    let min = c.vector("grid.min", &g.min, d);
    let max = c.vector("grid.max", &g.max, d);
    let dx = c.positive("grid.dx", g.dx);
    if min.len() == d && max.len() == d {
        for a in 0..d {
            if min[a].is_finite() && max[a].is_finite() && max[a] <= min[a] {
                c.err(
                    &format!("grid.max[{a}]"),
                    format!("must exceed grid.min[{a}] = {}", min[a]),
                );
            }
        }
        if dx > 0.0 && dx.is_finite() {
            let nodes: f64 = (0..d)
                .map(|a| ((max[a] - min[a]) / dx).abs().ceil() + 1.0)
                .product();
            if nodes > MAX_GRID_NODES || nodes.is_nan() {
                c.err(
                    "grid.dx",
                    format!(
                        "the grid would have {nodes:.3e} nodes (limit {MAX_GRID_NODES:.0e}): \
                         increase dx or shrink the domain"
                    ),
                );
            }
        }
    }
    Grid {
        min,
        max,
        dx,
        kernel: g.kernel.unwrap_or(KernelKind::Quadratic),
    }
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
            m.bulk_modulus = Some(2e5);
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

fn resolve_material(c: &mut Checker<'_>, i: usize, m: &RawMaterial, d: usize) -> MaterialDef {
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
        Some(rho) => c.positive(&k("density"), rho),
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

fn resolve_body(
    c: &mut Checker<'_>,
    i: usize,
    b: &RawBody,
    d: usize,
    materials: &[MaterialDef],
    base: &Path,
) -> Option<BodyDef> {
    let k = |name: &str| format!("bodies[{i}].{name}");
    let name = b.name.clone().unwrap_or_else(|| format!("body{i}"));
    let material_index = match materials.iter().position(|m| m.name == b.material) {
        Some(idx) => idx,
        None => {
            let names: Vec<_> = materials
                .iter()
                .map(|m| format!("\"{}\"", m.name))
                .collect();
            c.err(
                &k("material"),
                format!(
                    "unknown material \"{}\" (defined: {})",
                    b.material,
                    if names.is_empty() {
                        "none".to_string()
                    } else {
                        names.join(", ")
                    }
                ),
            );
            0
        }
    };
    let phase = b.phase.unwrap_or(0);
    if phase >= MAX_PHASES {
        c.err(
            &k("phase"),
            format!("must be below {MAX_PHASES} (got {phase})"),
        );
    }
    let has = |key: &str| -> bool {
        match key {
            "min" => b.min.is_some(),
            "max" => b.max.is_some(),
            "center" => b.center.is_some(),
            "radius" => b.radius.is_some(),
            "axis" => b.axis.is_some(),
            "half_length" => b.half_length.is_some(),
            "file" => b.file.is_some(),
            "scale" => b.scale.is_some(),
            "rotation" => b.rotation.is_some(),
            "translation" => b.translation.is_some(),
            _ => false,
        }
    };
    let all = [
        "min",
        "max",
        "center",
        "radius",
        "axis",
        "half_length",
        "file",
        "scale",
        "rotation",
        "translation",
    ];
    let used: &[&str] = match b.shape {
        ShapeKind::Box => &["min", "max"],
        ShapeKind::Sphere => &["center", "radius"],
        ShapeKind::Cylinder => &["center", "axis", "radius", "half_length"],
        ShapeKind::Mesh => &["file", "scale", "rotation", "translation"],
    };
    let shape_name = serde_plain(&b.shape);
    for key in all {
        if !used.contains(&key) {
            c.not_applicable(&k(key), has(key), &format!("to shape = \"{shape_name}\""));
        }
    }
    let need_vec = |c: &mut Checker<'_>, key: &str, v: &Option<Vec<f64>>| -> Vec<f64> {
        match v {
            Some(v) => c.vector(&k(key), v, d),
            None => {
                c.err(
                    &k(key),
                    format!("missing key: shape = \"{shape_name}\" needs `{key}`"),
                );
                vec![0.0; d]
            }
        }
    };
    let need_num = |c: &mut Checker<'_>, key: &str, v: Option<f64>| -> f64 {
        match v {
            Some(v) => c.positive(&k(key), v),
            None => {
                c.err(
                    &k(key),
                    format!("missing key: shape = \"{shape_name}\" needs `{key}`"),
                );
                1.0
            }
        }
    };
    let shape = match b.shape {
        ShapeKind::Box => {
            let min = need_vec(c, "min", &b.min);
            let max = need_vec(c, "max", &b.max);
            if min.len() == d && max.len() == d {
                for a in 0..d {
                    if max[a] <= min[a] {
                        c.err(
                            &k(&format!("max[{a}]")),
                            format!("must exceed min[{a}] = {}", min[a]),
                        );
                    }
                }
            }
            ShapeDef::Box { min, max }
        }
        ShapeKind::Sphere => ShapeDef::Sphere {
            center: need_vec(c, "center", &b.center),
            radius: need_num(c, "radius", b.radius),
        },
        ShapeKind::Cylinder => {
            let axis = need_vec(c, "axis", &b.axis);
            if axis.len() == d && axis.iter().all(|x| x.is_finite()) {
                let n: f64 = axis.iter().map(|x| x * x).sum::<f64>().sqrt();
                if !(n > 0.0 && n.is_finite()) {
                    c.err(&k("axis"), "must be a non-zero vector");
                }
            }
            ShapeDef::Cylinder {
                center: need_vec(c, "center", &b.center),
                axis,
                radius: need_num(c, "radius", b.radius),
                half_length: need_num(c, "half_length", b.half_length),
            }
        }
        ShapeKind::Mesh => {
            if d != 3 {
                c.err(
                    &k("shape"),
                    "shape = \"mesh\" needs dim = 3 (a mesh cannot be sampled in 2D)",
                );
            }
            let file = match &b.file {
                Some(f) if !f.trim().is_empty() => f.clone(),
                Some(_) => {
                    c.err(&k("file"), "must name an OBJ file");
                    String::new()
                }
                None => {
                    c.err(&k("file"), "missing key: shape = \"mesh\" needs `file`");
                    String::new()
                }
            };
            let scale = match &b.scale {
                None => vec![1.0; 3],
                Some(NumberOrList::Number(s)) => vec![*s; 3],
                Some(NumberOrList::List(v)) => c.vector(&k("scale"), v, 3),
            };
            if scale.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
                c.err(&k("scale"), "scale factors must be positive finite numbers");
            }
            let rotation = match &b.rotation {
                Some(r) => c.vector(&k("rotation"), r, 3),
                None => vec![0.0; 3],
            };
            let translation = match &b.translation {
                Some(t) => c.vector(&k("translation"), t, 3),
                None => vec![0.0; 3],
            };
            ShapeDef::Mesh {
                path: base.join(&file),
                file,
                scale,
                rotation,
                translation,
            }
        }
    };
    let sampling = match b.sampling.unwrap_or(SamplingKind::Lattice) {
        SamplingKind::Lattice => {
            c.not_applicable(
                &k("poisson_radius"),
                b.poisson_radius.is_some(),
                "to sampling = \"lattice\"",
            );
            let per_axis = b.per_axis.unwrap_or(2);
            if !(1..=8).contains(&per_axis) {
                c.err(
                    &k("per_axis"),
                    format!("must lie in 1..=8 (got {per_axis})"),
                );
            }
            SamplingDef::Lattice {
                per_axis,
                jitter: c.num(
                    &k("jitter"),
                    b.jitter.unwrap_or(0.0),
                    |j| (0.0..0.5).contains(&j),
                    "must lie in [0, 0.5)",
                ),
                seed: b.seed.unwrap_or(0),
            }
        }
        SamplingKind::Poisson => {
            for key in ["per_axis", "jitter"] {
                let present = if key == "per_axis" {
                    b.per_axis.is_some()
                } else {
                    b.jitter.is_some()
                };
                c.not_applicable(&k(key), present, "to sampling = \"poisson\"");
            }
            let r = match b.poisson_radius {
                Some(r) => c.positive(&k("poisson_radius"), r),
                None => {
                    c.err(
                        &k("poisson_radius"),
                        "missing key: sampling = \"poisson\" needs `poisson_radius` (m)",
                    );
                    1.0
                }
            };
            SamplingDef::Poisson {
                poisson_radius: r,
                seed: b.seed.unwrap_or(0),
            }
        }
    };
    let velocity = match &b.velocity {
        Some(v) => c.vector(&k("velocity"), v, d),
        None => vec![0.0; d],
    };
    if b.velocity_gradient.is_some() && b.angular_velocity.is_some() {
        c.err(
            &k("angular_velocity"),
            "give either velocity_gradient or angular_velocity, not both",
        );
    }
    let velocity_gradient = b.velocity_gradient.as_ref().map(|rows| {
        if rows.len() != d || rows.iter().any(|r| r.len() != d) {
            c.err(
                &k("velocity_gradient"),
                format!("must be a {d}×{d} matrix (a list of {d} rows of {d} numbers)"),
            );
        } else if rows.iter().flatten().any(|x| !x.is_finite()) {
            c.err(&k("velocity_gradient"), "must be finite numbers");
        }
        rows.clone()
    });
    let angular_velocity = b.angular_velocity.as_ref().map(|w| {
        match (d, w) {
            (2, NumberOrList::Number(x)) => {
                if !x.is_finite() {
                    c.err(&k("angular_velocity"), format!("must be finite (got {x})"));
                }
            }
            (3, NumberOrList::List(v)) => {
                c.vector(&k("angular_velocity"), v, 3);
            }
            _ => c.err(
                &k("angular_velocity"),
                if d == 2 {
                    "in 2D, angular_velocity is one number (rad/s)"
                } else {
                    "in 3D, angular_velocity is a vector [wx, wy, wz] (rad/s)"
                },
            ),
        }
        w.clone()
    });
    let about = if velocity_gradient.is_some() || angular_velocity.is_some() {
        Some(match &b.about {
            Some(p) => c.vector(&k("about"), p, d),
            None => shape_center(&shape, d),
        })
    } else {
        c.not_applicable(
            &k("about"),
            b.about.is_some(),
            "without velocity_gradient or angular_velocity",
        );
        None
    };
    Some(BodyDef {
        name,
        material: b.material.clone(),
        material_index,
        phase,
        shape,
        sampling,
        velocity,
        velocity_gradient,
        angular_velocity,
        about,
        initial_phi_eff: None,
        concentration: None,
    })
}

/// Centre of a shape's bounding box (mesh: its translation).
fn shape_center(s: &ShapeDef, d: usize) -> Vec<f64> {
    match s {
        ShapeDef::Box { min, max } => min.iter().zip(max).map(|(a, b)| 0.5 * (a + b)).collect(),
        ShapeDef::Sphere { center, .. } | ShapeDef::Cylinder { center, .. } => center.clone(),
        ShapeDef::Mesh { translation, .. } => {
            let mut t = translation.clone();
            t.resize(d, 0.0);
            t
        }
    }
}

/// The TOML spelling of a keyword enum value.
fn serde_plain<T: Serialize>(v: &T) -> String {
    serde_json::to_value(v)
        .ok()
        .and_then(|j| j.as_str().map(str::to_string))
        .unwrap_or_default()
}

fn resolve_boundary(
    c: &mut Checker<'_>,
    i: usize,
    b: &RawBoundary,
    d: usize,
) -> Option<BoundaryDef> {
    let k = |name: &str| format!("boundaries[{i}].{name}");
    let kind_name = serde_plain(&b.kind);
    let present = [
        ("thickness", b.thickness.is_some()),
        ("point", b.point.is_some()),
        ("normal", b.normal.is_some()),
        ("min", b.min.is_some()),
        ("max", b.max.is_some()),
        ("center", b.center.is_some()),
        ("radius", b.radius.is_some()),
        ("velocity", b.velocity.is_some()),
    ];
    let used: &[&str] = match b.kind {
        BoundaryKind::Walls => &["thickness"],
        BoundaryKind::HalfSpace => &["point", "normal", "velocity"],
        BoundaryKind::Box => &["min", "max", "velocity"],
        BoundaryKind::Sphere => &["center", "radius", "velocity"],
    };
    for (key, p) in present {
        if !used.contains(&key) {
            c.not_applicable(&k(key), p, &format!("to type = \"{kind_name}\""));
        }
    }
    let need_vec = |c: &mut Checker<'_>, key: &str, v: &Option<Vec<f64>>| -> Vec<f64> {
        match v {
            Some(v) => c.vector(&k(key), v, d),
            None => {
                c.err(
                    &k(key),
                    format!("missing key: type = \"{kind_name}\" needs `{key}`"),
                );
                vec![0.0; d]
            }
        }
    };
    let geometry = match b.kind {
        BoundaryKind::Walls => {
            let t = b.thickness.unwrap_or(3);
            if !(1..=16).contains(&t) {
                c.err(&k("thickness"), format!("must lie in 1..=16 (got {t})"));
            }
            BoundaryGeometry::Walls { thickness: t }
        }
        BoundaryKind::HalfSpace => {
            let point = need_vec(c, "point", &b.point);
            let normal = need_vec(c, "normal", &b.normal);
            let n: f64 = normal.iter().map(|x| x * x).sum::<f64>().sqrt();
            if normal.len() == d && !(n > 0.0 && n.is_finite()) {
                c.err(&k("normal"), "must be a non-zero finite vector");
            }
            BoundaryGeometry::HalfSpace { point, normal }
        }
        BoundaryKind::Box => {
            let min = need_vec(c, "min", &b.min);
            let max = need_vec(c, "max", &b.max);
            if min.len() == d && max.len() == d {
                for a in 0..d {
                    if max[a] <= min[a] {
                        c.err(
                            &k(&format!("max[{a}]")),
                            format!("must exceed min[{a}] = {}", min[a]),
                        );
                    }
                }
            }
            BoundaryGeometry::Box { min, max }
        }
        BoundaryKind::Sphere => {
            let center = need_vec(c, "center", &b.center);
            let radius = match b.radius {
                Some(r) => c.positive(&k("radius"), r),
                None => {
                    c.err(
                        &k("radius"),
                        "missing key: type = \"sphere\" needs `radius`",
                    );
                    1.0
                }
            };
            BoundaryGeometry::Sphere { center, radius }
        }
    };
    let velocity = if b.kind == BoundaryKind::Walls {
        None
    } else {
        Some(match &b.velocity {
            Some(v) => c.vector(&k("velocity"), v, d),
            None => vec![0.0; d],
        })
    };
    Some(BoundaryDef {
        geometry,
        contact: b.contact.unwrap_or(ContactName::Slip),
        friction: c.non_negative(&k("friction"), b.friction.unwrap_or(0.0)),
        velocity,
    })
}

/// Every snapshot field name that can exist, in file order, and when it exists.
pub fn field_names(columns: &Columns) -> Vec<&'static str> {
    let mut names = vec!["x", "v", "mass", "volume0", "material", "affine"];
    if columns.deformation_gradient {
        names.push("F");
    }
    if columns.jacobian {
        names.push("J");
    }
    if columns.plastic {
        names.push("plastic");
    }
    if columns.phase {
        names.push("phase");
    }
    if columns.volume_fraction {
        names.push("phi_eff");
    }
    if columns.concentration {
        names.push("concentration");
    }
    names.push("pressure");
    names
}

fn resolve_output(
    c: &mut Checker<'_>,
    o: Option<&RawOutput>,
    duration: &Duration,
    columns: &Columns,
    has_fluid: bool,
    stem: &str,
) -> OutputDef {
    let directory = o
        .and_then(|o| o.directory.clone())
        .unwrap_or_else(|| format!("out/{stem}"));
    if directory.trim().is_empty() {
        c.err("output.directory", "must not be empty");
    }
    let default_interval = match *duration {
        Duration::EndTime { end_time } => Interval::Time {
            interval: end_time / 50.0,
        },
        Duration::Steps { steps } => Interval::Steps {
            interval_steps: (steps / 50).max(1),
        },
    };
    let interval = resolve_interval(
        c,
        "output",
        o.and_then(|o| o.interval),
        o.and_then(|o| o.interval_steps),
    )
    .unwrap_or(default_interval);
    let available = field_names(columns);
    let fields = match o.and_then(|o| o.fields.as_ref()) {
        None => available
            .iter()
            .filter(|f| **f != "pressure" || has_fluid)
            .map(|s| s.to_string())
            .collect(),
        Some(list) => {
            let mut out: Vec<String> = Vec::new();
            for (i, f) in list.iter().enumerate() {
                let all = [
                    "x",
                    "v",
                    "mass",
                    "volume0",
                    "material",
                    "affine",
                    "F",
                    "J",
                    "plastic",
                    "phase",
                    "phi_eff",
                    "concentration",
                    "pressure",
                ];
                if !all.contains(&f.as_str()) {
                    c.err(
                        &format!("output.fields[{i}]"),
                        format!("unknown field \"{f}\" (known: {})", all.join(", ")),
                    );
                } else if !available.contains(&f.as_str()) {
                    c.err(
                        &format!("output.fields[{i}]"),
                        format!(
                            "field \"{f}\" does not exist in this scene (its particles have: {})",
                            available.join(", ")
                        ),
                    );
                } else if out.contains(f) {
                    c.err(
                        &format!("output.fields[{i}]"),
                        format!("field \"{f}\" is listed twice"),
                    );
                } else {
                    out.push(f.clone());
                }
            }
            // Positions are always written: the XDMF geometry needs them.
            if !out.iter().any(|f| f == "x") {
                out.insert(0, "x".to_string());
            }
            // File order follows `available`.
            available
                .iter()
                .filter(|a| out.iter().any(|f| f == *a))
                .map(|s| s.to_string())
                .collect()
        }
    };
    OutputDef {
        directory,
        interval,
        fields,
    }
}

/// The interval of table `table` (`output` or `checkpoint`) from its `interval` (s) and
/// `interval_steps` keys; `None` when neither is given. Giving both, or zero steps, is an error.
fn resolve_interval(
    c: &mut Checker<'_>,
    table: &str,
    interval: Option<f64>,
    steps: Option<u64>,
) -> Option<Interval> {
    match (interval, steps) {
        (Some(_), Some(_)) => {
            c.err(
                &format!("{table}.interval_steps"),
                "give either `interval` (s) or `interval_steps`, not both",
            );
            Some(Interval::Steps { interval_steps: 1 })
        }
        (Some(t), None) => Some(Interval::Time {
            interval: c.positive(&format!("{table}.interval"), t),
        }),
        (None, Some(n)) => {
            if n == 0 {
                c.err(&format!("{table}.interval_steps"), "must be at least 1");
            }
            Some(Interval::Steps { interval_steps: n })
        }
        (None, None) => None,
    }
}

fn resolve_checkpoint(c: &mut Checker<'_>, ck: &RawCheckpoint) -> CheckpointDef {
    let interval = resolve_interval(c, "checkpoint", ck.interval, ck.interval_steps)
        .unwrap_or_else(|| {
            c.err(
                "checkpoint.interval",
                "missing key: give `interval` (s) or `interval_steps`",
            );
            Interval::Steps { interval_steps: 1 }
        });
    let keep = ck.keep.unwrap_or(2);
    if keep == 0 {
        c.err("checkpoint.keep", "must be at least 1");
    }
    CheckpointDef { interval, keep }
}

impl Scene {
    /// Number of phases (grids): one more than the largest body phase.
    pub fn phase_count(&self) -> u32 {
        phase_count(&self.bodies)
    }

    /// The particle columns this scene needs: those of its materials, plus `phase` with more
    /// than one phase, `phi_eff` with `[porous]` and `concentration` with `[mixing]`.
    pub fn columns(&self) -> Columns {
        let materials: Vec<Material> = self.materials.iter().map(|m| m.model.material()).collect();
        columns_for(
            &materials,
            self.phase_count(),
            self.porous.is_some(),
            self.mixing.is_some() || self.dissolution.is_some(),
        )
    }

    /// The resolved scene as TOML, every default filled in.
    pub fn to_toml(&self) -> String {
        toml::to_string(self).unwrap_or_else(|e| format!("# (cannot print the scene: {e})\n"))
    }
}
