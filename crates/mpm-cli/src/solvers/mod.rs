//! The solver registry: every solver a scene can choose with `simulation.solver`. Each solver
//! has a directory `solvers/<module>/` with a scene module (`scene.rs`, which lists the tables
//! and keys only that solver reads and resolves them) and a build module (`build.rs`, which ends
//! in one `build` function that makes the solver from the resolved scene).
//!
//! A new solver adds its directory and one line to the `solvers!` list at the end of this file
//! (or moves its name there from the reserved names); no other file of the CLI changes.

use crate::build::{Built, Start};
use crate::error::SceneError;
use crate::scene::{resolve_solver, BodyDef, Checker, Common, LoadedScene, SolverTables};
use mpm_core::{Columns, Dim, DimOps};
use serde::{Deserialize, Serialize};
use toml::de::DeTable;
use toml::Spanned;

/// The tables and keys one solver reads and no common table holds.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Owned {
    /// The solver.
    pub kind: SolverKind,
    /// Its top-level tables ([`SolverTables::TABLES`]).
    pub tables: &'static [&'static str],
    /// Its keys inside the common tables ([`SolverTables::KEYS`]).
    pub keys: &'static [&'static str],
    /// The output fields only it computes ([`SolverTables::FIELDS`]).
    pub fields: &'static [&'static str],
    /// Whether its grid is sparse ([`SolverTables::SPARSE_GRID`]).
    pub sparse_grid: bool,
    /// Whether its fluids are incompressible ([`SolverTables::INCOMPRESSIBLE_FLUID`]).
    pub incompressible_fluid: bool,
    /// Whether it mirrors walls ([`SolverTables::MIRRORED_WALLS`]).
    pub mirrored_walls: bool,
}

impl Owned {
    /// Whether the solver reads the table or key `pattern`.
    pub fn reads(&self, pattern: &str) -> bool {
        self.tables.contains(&pattern) || self.keys.contains(&pattern)
    }
}

/// Whether solver `kind` stores only the grid blocks material reaches.
pub fn sparse_grid(kind: SolverKind) -> bool {
    OWNED.iter().any(|o| o.kind == kind && o.sparse_grid)
}

/// Whether the fluids of solver `kind` are incompressible (they take no equation of state).
pub fn incompressible_fluid(kind: SolverKind) -> bool {
    OWNED
        .iter()
        .any(|o| o.kind == kind && o.incompressible_fluid)
}

/// Whether solver `kind` mirrors its grid across walls.
pub fn mirrored_walls(kind: SolverKind) -> bool {
    OWNED.iter().any(|o| o.kind == kind && o.mirrored_walls)
}

/// Whether solver `kind` can run a scene (it is not only a reserved name).
pub fn available(kind: SolverKind) -> bool {
    OWNED.iter().any(|o| o.kind == kind)
}

/// The names of the solvers that can run a scene, for messages: `"explicit" and "tlmpm"`.
pub fn available_names() -> String {
    let names: Vec<String> = OWNED
        .iter()
        .map(|o| format!("\"{}\"", o.kind.name()))
        .collect();
    match names.split_last() {
        Some((last, rest)) if !rest.is_empty() => format!("{} and {last}", rest.join(", ")),
        _ => names.concat(),
    }
}

/// Declares the solver modules and defines [`SolverKind`], [`SolverScene`], [`OWNED`] and the
/// dispatch to each solver's scene and build modules from one line per solver,
/// `Variant = "name" => module::SceneType`: the module is `solvers/module/`, its scene module
/// `module::scene`, whose `SceneType` implements [`SolverTables`], and its build module
/// `module::build`, whose `build` makes the solver. A line ending in `if <cfg>` (e.g.
/// `if feature = "ballistic"`) registers the solver only in builds where the cfg holds.
/// Reserved names are solvers a scene may name that cannot run yet.
macro_rules! solvers {
    (
        available {
            $(
                $(#[$doc:meta])* $kind:ident = $name:literal => $module:ident::$part:ident
                $(if $cfg:meta)?,
            )+
        }
        reserved {
            $($(#[$rdoc:meta])* $rkind:ident = $rname:literal,)*
        }
    ) => {
        $($(#[cfg($cfg)])? pub mod $module;)+

        /// Which solver runs the scene (`simulation.solver`).
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
        pub enum SolverKind {
            $($(#[cfg($cfg)])? $(#[$doc])* #[serde(rename = $name)] $kind,)+
            $($(#[$rdoc])* #[serde(rename = $rname)] $rkind,)*
        }

        impl SolverKind {
            /// The name a scene gives in `simulation.solver`.
            pub fn name(self) -> &'static str {
                match self {
                    $($(#[cfg($cfg)])? SolverKind::$kind => $name,)+
                    $(SolverKind::$rkind => $rname,)*
                }
            }
        }

        /// The tables of the solver a scene runs, resolved by that solver's scene module.
        #[derive(Clone, Debug, PartialEq, Serialize)]
        #[serde(untagged)]
        pub enum SolverScene {
            $($(#[cfg($cfg)])? $(#[$doc])* $kind($module::scene::$part),)+
        }

        /// The tables and keys of every solver that can run a scene, in registry order.
        pub(crate) const OWNED: &[Owned] = &[$($(#[cfg($cfg)])? Owned {
            kind: SolverKind::$kind,
            tables: <$module::scene::$part as SolverTables>::TABLES,
            keys: <$module::scene::$part as SolverTables>::KEYS,
            fields: <$module::scene::$part as SolverTables>::FIELDS,
            sparse_grid: <$module::scene::$part as SolverTables>::SPARSE_GRID,
            incompressible_fluid: <$module::scene::$part as SolverTables>::INCOMPRESSIBLE_FLUID,
            mirrored_walls: <$module::scene::$part as SolverTables>::MIRRORED_WALLS,
        },)+];

        impl SolverScene {
            /// The solver.
            pub fn kind(&self) -> SolverKind {
                match self {
                    $($(#[cfg($cfg)])? SolverScene::$kind(_) => SolverKind::$kind,)+
                }
            }

            /// Reads and resolves the tables of solver `kind`; `None` for a reserved name or
            /// after a parser error in the tables (both recorded in `c`).
            pub(crate) fn resolve(
                kind: SolverKind,
                c: &mut Checker<'_>,
                tables: Spanned<DeTable<'_>>,
                common: Common<'_>,
            ) -> Option<Self> {
                match kind {
                    $($(#[cfg($cfg)])? SolverKind::$kind => {
                        resolve_solver::<$module::scene::$part>(c, tables, common)
                            .map(SolverScene::$kind)
                    })+
                    $(SolverKind::$rkind => None,)*
                }
            }

            /// The output fields only this solver computes.
            pub(crate) fn fields(&self) -> &'static [&'static str] {
                match self {
                    $($(#[cfg($cfg)])? SolverScene::$kind(_) => {
                        <$module::scene::$part as SolverTables>::FIELDS
                    })+
                }
            }

            /// Whether `check` prints the tables after `[output]` and `[checkpoint]`.
            pub(crate) fn printed_last(&self) -> bool {
                match self {
                    $($(#[cfg($cfg)])? SolverScene::$kind(_) => {
                        <$module::scene::$part as SolverTables>::PRINTED_LAST
                    })+
                }
            }

            /// The particle columns of the scene, given those its materials need.
            pub(crate) fn columns(&self, materials: Columns, bodies: &[BodyDef]) -> Columns {
                match self {
                    $($(#[cfg($cfg)])? SolverScene::$kind(s) => s.columns(materials, bodies),)+
                }
            }

            /// Builds the solver from the sampled scene (the solver's build module).
            pub(crate) fn build<const D: usize>(
                &self,
                scene: &LoadedScene,
                start: Start<D>,
            ) -> Result<Built<D>, SceneError>
            where
                Dim<D>: DimOps<D>,
            {
                match self {
                    $($(#[cfg($cfg)])? SolverScene::$kind(s) => $module::build::build(scene, s, start),)+
                }
            }
        }
    };
}

solvers! {
    available {
        /// Explicit MLS-MPM (`mpm-explicit`), on one grid or several coupled ones.
        Explicit = "explicit" => explicit::ExplicitScene,
        /// Total-Lagrangian MPM (`mpm-tlmpm`), implicit or explicit; see `[tlmpm]`.
        Tlmpm = "tlmpm" => tlmpm::TlmpmScene,
        /// DIQ-MPM's incompressible fluid (`mpm-diq`); see `[diq]`.
        Diq = "diq" => diq::DiqScene,
        /// A toy: particles in free flight bouncing off the grid box (`mpm-ballistic`).
        Ballistic = "ballistic" => ballistic::BallisticScene if feature = "ballistic",
    }
    reserved {
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::COMMON_TABLES;

    #[test]
    fn solvers_own_no_common_table_and_only_keys_inside_common_tables() {
        assert!(available(SolverKind::Explicit) && available(SolverKind::Tlmpm));
        assert!(available(SolverKind::Diq));
        assert_eq!(available_names(), "\"explicit\", \"tlmpm\" and \"diq\"");
        for o in OWNED {
            for t in o.tables {
                assert!(!COMMON_TABLES.contains(t), "{t} is a common table");
            }
            for k in o.keys {
                let table = k.split(['.', '[']).next().unwrap_or("");
                assert!(
                    COMMON_TABLES.contains(&table),
                    "{k} is not in a common table"
                );
            }
        }
    }

    #[test]
    fn names_are_the_scene_spellings() {
        for (kind, name) in [
            (SolverKind::Explicit, "explicit"),
            (SolverKind::Tlmpm, "tlmpm"),
            (SolverKind::Diq, "diq"),
        ] {
            assert_eq!(kind.name(), name);
            assert_eq!(crate::scene::serde_plain(&kind), name);
        }
    }
}
