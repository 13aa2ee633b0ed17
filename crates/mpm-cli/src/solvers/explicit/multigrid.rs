//! The multi-grid tables of the explicit solver (multigrid paper §4): `[[couplings]]` between
//! phase grids, `[porous]` interaction, `[mixing]` of two fluids and `[dissolution]` of a solid.

use crate::scene::bodies::BodyDef;
use crate::scene::materials::{is_fluid, material_index, MaterialDef};
use crate::scene::{serde_plain, Checker};
use mpm_core::material::Parameter;
use mpm_core::{Kernel, Material};
use mpm_explicit::{Activation, DiffusionScheme, EffectiveFraction};
use serde::{Deserialize, Serialize};

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

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawCoupling {
    phases: Vec<u32>,
    kind: CouplingName,
    coefficient: Option<f64>,
    porosity: Option<f64>,
    conductivity: Option<f64>,
    normal_share: Option<f64>,
    friction: Option<f64>,
    friction_model: Option<FrictionModel>,
    apply: Option<Activation>,
    buoyancy: Option<f64>,
    pressure_buoyancy: Option<bool>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawPorous {
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
pub(crate) struct RawMixing {
    fluids: Vec<String>,
    diffusivity: Option<f64>,
    scheme: Option<DiffusionScheme>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawDissolution {
    solid: String,
    into: String,
    rate: Option<f64>,
    fluid_phase: Option<u32>,
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
    pub apply: Activation,
}

/// `[porous]`: the effective volume fraction and the parameters it scales.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PorousDef {
    /// Update rule of φ_eff.
    #[serde(flatten)]
    pub phi_eff: EffectiveFraction,
    /// Initial φ_eff of bodies that do not set their own (dimensionless).
    pub initial_phi_eff: f64,
    /// `[[porous.interactions]]`.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub interactions: Vec<InteractionDef>,
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
    pub scheme: DiffusionScheme,
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

/// Resolves `[[couplings]]` between the `phases` phase grids; a pair of phases is coupled once.
pub(super) fn resolve_couplings(
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
            apply: r.apply.unwrap_or(Activation::OnApproach),
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

/// Resolves `[porous]`, which needs at least two phases.
pub(super) fn resolve_porous(
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
                EffectiveFraction::Current
            } else {
                EffectiveFraction::Max
            }
        }
        PhiEffRule::Relax => EffectiveFraction::Relax { rate: rate(c) },
        PhiEffRule::MaxRelax => EffectiveFraction::MaxRelax { rate: rate(c) },
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

/// Resolves `[mixing]`: two distinct fluids whose bodies share one phase.
pub(super) fn resolve_mixing(
    c: &mut Checker<'_>,
    m: &RawMixing,
    materials: &[MaterialDef],
    bodies: &[BodyDef],
    kernel: Kernel,
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
    let scheme = m.scheme.unwrap_or(DiffusionScheme::KernelGradient);
    if scheme == DiffusionScheme::MlsDifference && kernel == Kernel::Linear {
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

/// Resolves `[dissolution]` into the second fluid of `mixing`, with the solvent's phase.
pub(super) fn resolve_dissolution(
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
