//! The scene format: TOML in SI units (documented key by key in `docs/scenes.md`).
//!
//! A scene is read in two passes. First the TOML document is split into the tables every scene
//! may have ([`COMMON_TABLES`]) and the tables that belong to one solver (each solver's scene
//! module lists them); a top-level key that is neither is an error.
//! Serde reads the common tables into `Raw*` structs that reject unknown keys and wrong types (the
//! TOML parser gives their span). Then the resolvers check every value, fill in defaults and
//! presets, and produce a [`Scene`]; each problem they find names its key path (e.g.
//! `materials[1].E`) and the key's span in the file, found through a [`SpanIndex`]. The solver
//! named by `simulation.solver` reads and resolves its own tables; the tables and keys that only
//! other solvers read are errors at their place in the file. [`Scene`] serialises back to TOML in
//! the same format with every default filled in, which is what `mpm-cli check` prints.
//!
//! The modules follow the tables: [`simulation`], [`grid`], [`materials`], [`bodies`],
//! [`boundaries`] and [`output`] are common to every solver; each solver's scene module is in
//! its directory under [`crate::solvers`].

use crate::error::{CliError, Diagnostic, SceneError};
use crate::input::{read_text, MAX_SCENE_BYTES};
use crate::solvers::{self, SolverScene};
use crate::span::SpanIndex;
use mpm_core::{Columns, Material};
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize, Serializer};
use std::path::{Path, PathBuf};
use toml::de::{DeTable, Deserializer};
use toml::Spanned;

pub mod bodies;
pub mod boundaries;
pub mod grid;
pub mod materials;
pub mod output;
pub mod overrides;
pub mod simulation;

#[cfg(test)]
mod tests;

pub use crate::solvers::SolverKind;
pub use bodies::{
    BodyDef, NumberOrList, SamplingDef, SamplingKind, ShapeDef, ShapeKind, MAX_PHASES,
};
pub use boundaries::{BoundaryDef, BoundaryGeometry, BoundaryKind};
pub use grid::{Grid, MAX_GRID_BLOCKS, MAX_GRID_NODES};
pub use materials::{
    FluidDef, MaterialDef, ModelDef, ModelKind, PlasticityDef, PlasticityKind, Preset, SolidDef,
};
pub use output::{field_names, CheckpointDef, Interval, OutputDef, Precision};
pub use simulation::{
    Duration, InitialVolume, InstabilityAction, Simulation, TimeStepDef, TransferKind,
    FLIP_BLEND_DEFAULT,
};

/// The top-level tables every scene may have, whatever its solver.
pub const COMMON_TABLES: [&str; 7] = [
    "simulation",
    "grid",
    "materials",
    "bodies",
    "boundaries",
    "output",
    "checkpoint",
];

/// The common tables as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScene {
    simulation: simulation::RawSimulation,
    grid: grid::RawGrid,
    #[serde(default)]
    materials: Vec<materials::RawMaterial>,
    #[serde(default)]
    bodies: Vec<bodies::RawBody>,
    #[serde(default)]
    boundaries: Vec<boundaries::RawBoundary>,
    output: Option<output::RawOutput>,
    checkpoint: Option<output::RawCheckpoint>,
}

/// A validated scene with every default filled in.
#[derive(Clone, Debug, PartialEq)]
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
    pub boundaries: Vec<BoundaryDef>,
    /// The tables of the solver `simulation.solver` names.
    pub solver: SolverScene,
    /// `[output]`.
    pub output: OutputDef,
    /// `[checkpoint]`, if checkpoints are written.
    pub checkpoint: Option<CheckpointDef>,
}

/// A scene as `check` prints it: the common tables in the order of `docs/scenes.md`, with the
/// solver's tables before `[output]` or after `[checkpoint]` as its module says.
#[derive(Serialize)]
struct Printed<'a> {
    simulation: &'a Simulation,
    grid: &'a Grid,
    materials: &'a [MaterialDef],
    bodies: &'a [BodyDef],
    #[serde(skip_serializing_if = "<[BoundaryDef]>::is_empty")]
    boundaries: &'a [BoundaryDef],
    #[serde(flatten)]
    solver_before: Option<&'a SolverScene>,
    output: &'a OutputDef,
    #[serde(skip_serializing_if = "Option::is_none")]
    checkpoint: Option<&'a CheckpointDef>,
    #[serde(flatten)]
    solver_after: Option<&'a SolverScene>,
}

impl Serialize for Scene {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let last = self.solver.printed_last();
        Printed {
            simulation: &self.simulation,
            grid: &self.grid,
            materials: &self.materials,
            bodies: &self.bodies,
            boundaries: &self.boundaries,
            solver_before: (!last).then_some(&self.solver),
            output: &self.output,
            checkpoint: self.checkpoint.as_ref(),
            solver_after: last.then_some(&self.solver),
        }
        .serialize(s)
    }
}

/// The scene module of a solver: the tables and keys only that solver reads, and how they
/// resolve. Registered with its build module in [`crate::solvers`].
pub(crate) trait SolverTables: Sized {
    /// Top-level tables (and arrays of tables) only this solver reads; `Raw` has one field for
    /// each.
    const TABLES: &'static [&'static str];
    /// Keys of the common tables only this solver reads, as key paths in which `[]` stands for
    /// any array index (`bodies[].phase`).
    const KEYS: &'static [&'static str];
    /// Whether `check` prints the solver's tables after `[output]` and `[checkpoint]` rather
    /// than before `[output]`.
    const PRINTED_LAST: bool;
    /// The solver's tables as written.
    type Raw: DeserializeOwned;
    /// Checks the solver's tables and the parts of the common ones it depends on, and fills in
    /// defaults.
    fn resolve(c: &mut Checker<'_>, raw: Self::Raw, common: Common<'_>) -> Self;
    /// The particle columns of the scene, given those its materials need.
    fn columns(&self, materials: Columns, bodies: &[BodyDef]) -> Columns;
    /// Output fields only this solver computes (beyond the particle columns and `pressure`).
    const FIELDS: &'static [&'static str] = &[];
    /// Whether the solver's grid stores only the node blocks material reaches (so `[grid]` is
    /// limited by the domain's blocks, not its nodes).
    const SPARSE_GRID: bool = false;
    /// Whether the solver's fluids are incompressible, so that they take no equation of state
    /// (`bulk_modulus` and `gamma` of a fluid material are refused).
    const INCOMPRESSIBLE_FLUID: bool = false;
    /// Whether the solver mirrors its grid across walls (`treatment = "mirror"`), so that
    /// walls without a `treatment` get the default one that converges.
    const MIRRORED_WALLS: bool = false;
}

/// The resolved common tables, as a solver's scene module sees them.
pub(crate) struct Common<'a> {
    /// `[simulation]`.
    pub simulation: &'a Simulation,
    /// `[grid]`.
    pub grid: &'a Grid,
    /// `[[materials]]`.
    pub materials: &'a [MaterialDef],
    /// `[[bodies]]`, which the solver may complete (the explicit solver's initial φ_eff and
    /// concentration).
    pub bodies: &'a mut [BodyDef],
    /// `[[bodies]]` as written.
    pub raw_bodies: &'a [bodies::RawBody],
    /// `[[boundaries]]`.
    pub boundaries: &'a [BoundaryDef],
}

/// Reads solver `T`'s tables out of `tables` (the solvers' tables present in the file) and
/// resolves them; a parser error in them is recorded and gives `None`.
pub(crate) fn resolve_solver<T: SolverTables>(
    c: &mut Checker<'_>,
    tables: Spanned<DeTable<'_>>,
    common: Common<'_>,
) -> Option<T> {
    let span = tables.span();
    let mut own = DeTable::new();
    for (key, value) in tables.into_inner() {
        if T::TABLES.contains(&key.get_ref().as_ref()) {
            own.insert(key, value);
        }
    }
    match T::Raw::deserialize(Deserializer::from(Spanned::new(span, own))) {
        Ok(raw) => Some(T::resolve(c, raw, common)),
        Err(e) => {
            let d = parser_diagnostic(c.spans, &e, c.text);
            c.items.push(d);
            None
        }
    }
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

/// Reads and resolves the scene file at `path`. A missing or unreadable file, one that is not a
/// regular file or is larger than [`MAX_SCENE_BYTES`], and every problem in it are bad input
/// (exit code 2).
pub fn load(path: &Path) -> Result<LoadedScene, CliError> {
    load_with(path, &[])
}

/// [`load`] with `--set` overrides applied to the text first (see [`overrides`]); the
/// resolved scene's text is the overridden one.
pub fn load_with(path: &Path, overrides: &[overrides::Override]) -> Result<LoadedScene, CliError> {
    let text = read_text(path, MAX_SCENE_BYTES).map_err(|e| {
        CliError::BadInput(format!(
            "error: cannot read scene file {}: {e}",
            path.display()
        ))
    })?;
    let text = if overrides.is_empty() {
        text
    } else {
        overrides::apply(&text, overrides).map_err(|e| CliError::BadInput(format!("error: {e}")))?
    };
    parse(path, &text).map_err(CliError::from)
}

/// Parses and resolves scene `text` read from `path` (relative mesh paths are resolved against
/// `path`'s directory).
pub fn parse(path: &Path, text: &str) -> Result<LoadedScene, SceneError> {
    let spans = SpanIndex::new(text);
    let one = |d: Diagnostic| SceneError::new(path, text, vec![d]);
    let parser = |e: toml::de::Error| one(parser_diagnostic(&spans, &e, text));
    let document = DeTable::parse(text).map_err(parser)?;
    let (common, solver_tables) = split_tables(document).map_err(one)?;
    let raw = RawScene::deserialize(Deserializer::from(common)).map_err(parser)?;
    let mut c = Checker {
        spans: &spans,
        text,
        items: Vec::new(),
        unreported: 0,
    };
    let scene = resolve(&mut c, raw, solver_tables, path);
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
            if c.unreported > 0 {
                items.push(Diagnostic {
                    key: None,
                    span: None,
                    message: format!(
                        "{} more problems not shown (at most {MAX_PROBLEMS} are reported)",
                        c.unreported
                    ),
                });
            }
            Err(SceneError::new(path, text, items))
        }
    }
}

/// Splits a document into its common tables and the solvers' tables. A top-level key that is
/// neither is an error naming every table a scene may have.
fn split_tables<'i>(
    document: Spanned<DeTable<'i>>,
) -> Result<(Spanned<DeTable<'i>>, Spanned<DeTable<'i>>), Diagnostic> {
    let span = document.span();
    let mut solver_tables: Vec<&str> = Vec::new();
    for &t in solvers::OWNED.iter().flat_map(|o| o.tables) {
        if !solver_tables.contains(&t) {
            solver_tables.push(t);
        }
    }
    let (mut common, mut solver) = (DeTable::new(), DeTable::new());
    for (key, value) in document.into_inner() {
        let name: &str = key.get_ref().as_ref();
        if COMMON_TABLES.contains(&name) {
            common.insert(key, value);
        } else if solver_tables.contains(&name) {
            solver.insert(key, value);
        } else {
            let known: Vec<String> = COMMON_TABLES
                .iter()
                .chain(&solver_tables)
                .map(|t| format!("`{t}`"))
                .collect();
            return Err(Diagnostic {
                key: Some(name.to_string()),
                span: Some(key.span()),
                message: format!(
                    "unknown field `{name}`, expected one of {}",
                    known.join(", ")
                ),
            });
        }
    }
    Ok((
        Spanned::new(span.clone(), common),
        Spanned::new(span, solver),
    ))
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

/// Collects the problems found while resolving a scene, each at its key.
pub(crate) struct Checker<'a> {
    spans: &'a SpanIndex,
    text: &'a str,
    items: Vec<Diagnostic>,
    /// Problems found beyond [`MAX_PROBLEMS`].
    unreported: usize,
}

/// Most problems reported for one scene: locating each costs time proportional to the scene's
/// size, and a scene with thousands of problems (say, ten thousand bodies naming a missing
/// material) is told enough by the first hundred.
pub const MAX_PROBLEMS: usize = 100;

impl Checker<'_> {
    /// Records a problem at `key`.
    pub(crate) fn err(&mut self, key: &str, message: impl Into<String>) {
        if self.items.len() >= MAX_PROBLEMS {
            self.unreported += 1;
            return;
        }
        self.items.push(Diagnostic {
            key: Some(key.to_string()),
            span: self.spans.locate(key),
            message: message.into(),
        });
    }

    /// A finite number satisfying `ok`, else an error `what`.
    pub(crate) fn num(&mut self, key: &str, v: f64, ok: impl Fn(f64) -> bool, what: &str) -> f64 {
        if !(v.is_finite() && ok(v)) {
            self.err(key, format!("{} (got {v})", what));
        }
        v
    }

    /// A positive finite number.
    pub(crate) fn positive(&mut self, key: &str, v: f64) -> f64 {
        self.num(key, v, |x| x > 0.0, "must be a positive finite number")
    }

    /// A finite number ≥ 0.
    pub(crate) fn non_negative(&mut self, key: &str, v: f64) -> f64 {
        self.num(key, v, |x| x >= 0.0, "must be a finite number ≥ 0")
    }

    /// A vector of `d` finite numbers.
    pub(crate) fn vector(&mut self, key: &str, v: &[f64], d: usize) -> Vec<f64> {
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

    /// A vector of `d` finite numbers that `what` (e.g. `shape = "box"`) requires at `key`.
    pub(crate) fn required_vector(
        &mut self,
        key: &str,
        v: Option<&[f64]>,
        d: usize,
        what: &str,
    ) -> Vec<f64> {
        match v {
            Some(v) => self.vector(key, v, d),
            None => {
                let name = key.rsplit('.').next().unwrap_or(key);
                self.err(key, format!("missing key: {what} needs `{name}`"));
                vec![0.0; d]
            }
        }
    }

    /// The corners `{key}.min` and `{key}.max` of a box: `max` must exceed `min` on every axis.
    pub(crate) fn box_corners(&mut self, key: &str, min: &[f64], max: &[f64], d: usize) {
        if min.len() == d && max.len() == d {
            for a in 0..d {
                if max[a] <= min[a] {
                    self.err(
                        &format!("{key}.max[{a}]"),
                        format!("must exceed min[{a}] = {}", min[a]),
                    );
                }
            }
        }
    }

    /// A required key.
    pub(crate) fn required<T: Clone>(&mut self, key: &str, v: &Option<T>, why: &str) -> Option<T> {
        if v.is_none() {
            self.err(key, format!("missing key: {why}"));
        }
        v.clone()
    }

    /// Rejects `key` when it is present (`present`) but does not apply.
    pub(crate) fn not_applicable(&mut self, key: &str, present: bool, why: &str) {
        if present {
            self.err(key, format!("does not apply {why}"));
        }
    }
}

fn resolve(
    c: &mut Checker<'_>,
    raw: RawScene,
    solver_tables: Spanned<DeTable<'_>>,
    path: &Path,
) -> Option<Scene> {
    let sim = simulation::resolve_simulation(c, &raw.simulation)?;
    let d = sim.dim;
    let sparse = crate::solvers::sparse_grid(sim.solver);
    let grid = grid::resolve_grid(c, &raw.grid, d, sparse);
    let materials = materials::resolve_materials(c, &raw.materials, d, sim.solver);
    let base = path.parent().unwrap_or(Path::new("."));
    let mut bodies = bodies::resolve_bodies(c, &raw.bodies, d, &materials, base);
    let mirrors = crate::solvers::mirrored_walls(sim.solver);
    let boundaries = boundaries::resolve_boundaries(c, &raw.boundaries, (&grid, d), mirrors);
    reject_other_solvers_keys(c, sim.solver);
    let common = Common {
        simulation: &sim,
        grid: &grid,
        materials: &materials,
        bodies: &mut bodies,
        raw_bodies: &raw.bodies,
        boundaries: &boundaries,
    };
    let solver = SolverScene::resolve(sim.solver, c, solver_tables, common)?;
    let core: Vec<Material> = materials.iter().map(|m| m.model.material()).collect();
    let columns = solver.columns(Columns::for_materials(&core), &bodies);
    let has_fluid = core.iter().any(|m| matches!(m, Material::Fluid(_)));
    let stem = path
        .file_stem()
        .map_or("scene".into(), |s| s.to_string_lossy().into_owned());
    let output = output::resolve_output(
        c,
        raw.output.as_ref(),
        &sim.duration,
        (&columns, solver.fields()),
        has_fluid,
        &stem,
    );
    let checkpoint = raw
        .checkpoint
        .as_ref()
        .map(|ck| output::resolve_checkpoint(c, ck));
    Some(Scene {
        simulation: sim,
        grid,
        materials,
        bodies,
        boundaries,
        solver,
        output,
        checkpoint,
    })
}

/// Rejects, at their place in the file, the tables and keys that only solvers other than
/// `chosen` read.
fn reject_other_solvers_keys(c: &mut Checker<'_>, chosen: SolverKind) {
    let Some(own) = solvers::OWNED.iter().find(|o| o.kind == chosen) else {
        return;
    };
    let mut done: Vec<&str> = Vec::new();
    for other in solvers::OWNED.iter().filter(|o| o.kind != chosen) {
        for &pattern in other.tables.iter().chain(other.keys) {
            if own.reads(pattern) || done.contains(&pattern) {
                continue;
            }
            done.push(pattern);
            let owners: Vec<String> = solvers::OWNED
                .iter()
                .filter(|o| o.reads(pattern))
                .map(|o| format!("\"{}\"", o.kind.name()))
                .collect();
            for path in c.spans.matching(pattern) {
                c.err(
                    &path,
                    format!(
                        "does not apply with solver \"{}\" (only with simulation.solver = {})",
                        chosen.name(),
                        owners.join(" or ")
                    ),
                );
            }
        }
    }
}

pub(crate) use mpm_core::sampling::count_text;

/// The TOML spelling of a keyword enum value.
pub(crate) fn serde_plain<T: Serialize>(v: &T) -> String {
    serde_json::to_value(v)
        .ok()
        .and_then(|j| j.as_str().map(str::to_string))
        .unwrap_or_default()
}

impl Scene {
    /// Number of phases (grids): one more than the largest body phase.
    pub fn phase_count(&self) -> u32 {
        bodies::phase_count(&self.bodies)
    }

    /// The particle columns this scene needs: those of its materials, plus those its solver's
    /// tables need (explicit: `phase` with more than one phase, `phi_eff` with `[porous]` and
    /// `concentration` with `[mixing]`).
    pub fn columns(&self) -> Columns {
        let materials: Vec<Material> = self.materials.iter().map(|m| m.model.material()).collect();
        self.solver
            .columns(Columns::for_materials(&materials), &self.bodies)
    }

    /// The resolved scene as TOML, every default filled in.
    pub fn to_toml(&self) -> String {
        toml::to_string(self).unwrap_or_else(|e| format!("# (cannot print the scene: {e})\n"))
    }
}
