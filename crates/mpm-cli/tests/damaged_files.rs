//! Fuzz test over every file kind: a snapshot and a checkpoint of each solver family (explicit,
//! TLMPM, DIQ), with their checksum block and without it (the block cut off, as a file another
//! HDF5 tool wrote). Each kind gets `VARIANTS` damaged copies: flipped bytes, overwritten and
//! zeroed ranges, copied ranges, truncation, appended bytes and cut first bytes.
//!
//! - With the block, every damaged copy is refused (exit 2): `info` and `run --resume`.
//! - Without the block, `info` and `run --resume` refuse every copy (exit 2), damaged or not.
//! - With `--unchecked`, reading and `run --resume` accept files without the block: they may
//!   succeed (damage to values goes unnoticed: that is what makes the option unsafe), exit 2
//!   (refused) or, for a resume, 3 (the damage made the run unstable), but never die by a
//!   signal, hang or exit otherwise: only a child process lets the HDF5 library read such a
//!   file, and it hands over a checksummed copy.
//!
//! `info` and the unchecked read (what `--unchecked info` reads) run in this process, the
//! latter with `mpm-cli` as its child; the resumes run the binary. The counts are printed per
//! kind and command; a copy that breaks a rule is kept and named.

mod common;

use common::*;
use mpm_cli::files::Checked;
use mpm_io::Verify;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Damaged copies per file kind.
const VARIANTS: usize = 402;

/// Every `RESUME_EVERY`-th copy of a checkpoint is also resumed from.
const RESUME_EVERY: usize = 15;

/// Seconds the child process reading an unchecked file may take (`MPM_UNCHECKED_TIMEOUT`):
/// each file here is read in about 17 ms (process start included); a damaged one that makes the
/// HDF5 library loop costs
/// this much.
const CHILD_TIMEOUT_S: &str = "0.2";

/// How long a command may take before it counts as a hang.
const TIMEOUT: Duration = Duration::from_secs(30);

/// Runs the binary with `args` (the child reading an unchecked file limited to
/// [`CHILD_TIMEOUT_S`]); returns how it ended and its stderr.
fn run(args: &[&str], dir: &Path) -> (Outcome, String) {
    let env = [(mpm_cli::files::TIMEOUT_VAR, CHILD_TIMEOUT_S)];
    let (outcome, _, stderr) = run_with_timeout(args, &env, dir, TIMEOUT);
    (outcome, stderr)
}

/// A damaged copy of `good`; the kind of damage cycles with `case`.
fn damage(good: &[u8], case: usize, rng: &mut Rng) -> Vec<u8> {
    let mut b = good.to_vec();
    let n = b.len();
    let at = rng.below(n);
    match case % 8 {
        0 => b[at] ^= 1 + rng.below(255) as u8,
        1 => {
            for byte in &mut b[at..(at + 8).min(n)] {
                *byte = rng.next() as u8;
            }
        }
        2 => b.truncate(at),
        3 => {
            b.drain(..[512, 1024][rng.below(2)].min(n));
        }
        4 => {
            for byte in &mut b[at..(at + 64).min(n)] {
                *byte = 0;
            }
        }
        5 => b.extend((0..1 + rng.below(100)).map(|_| rng.next() as u8)),
        // The first 4 KiB hold the superblock and most object headers.
        6 => b[rng.below(n.min(4096))] ^= 1 + rng.below(255) as u8,
        _ => {
            let from = rng.below(n - 256);
            let to = rng.below(n - 256);
            let chunk = good[from..from + 256].to_vec();
            b[to..to + 256].copy_from_slice(&chunk);
        }
    }
    if b == good {
        b.push(0);
    }
    b
}

/// One file kind: its name, the intact bytes, the scene that wrote it (for a resume) and
/// whether it is a checkpoint.
struct Kind {
    name: String,
    bytes: Vec<u8>,
    scene: PathBuf,
    checkpoint: bool,
    block: bool,
    /// For a checkpoint without the block: the outputs of `--unchecked run --resume` from the
    /// intact file.
    reference: Vec<(u64, Vec<u8>)>,
}

/// Outcome counts per (kind, command).
type Tally = BTreeMap<(String, &'static str), BTreeMap<String, usize>>;

/// Runs every damaged copy of `kind` in `dir`; returns the counts and the violations.
fn fuzz(kind: &Kind, dir: &Path, seed: u64) -> (Tally, Vec<String>) {
    let mut tally = Tally::new();
    let mut failures = Vec::new();
    let mut rng = Rng(seed);
    let file = dir.join("bad.h5");
    let f = file.to_string_lossy().into_owned();
    let (scene, out) = (
        kind.scene.to_string_lossy().into_owned(),
        dir.join("out").to_string_lossy().into_owned(),
    );
    for case in 0..VARIANTS {
        std::fs::write(&file, damage(&kind.bytes, case, &mut rng)).expect("write");
        let mut clock = Instant::now();
        let mut record = |cmd: &'static str, outcome: Outcome, message: &str, note: &str| {
            *tally
                .entry((kind.name.clone(), cmd))
                .or_default()
                .entry("seconds".into())
                .or_default() += clock.elapsed().as_micros() as usize;
            clock = Instant::now();
            let allowed: &[i32] = match cmd {
                "info" | "resume" => &[2],
                "--unchecked read" => &[0, 2],
                _ => &[0, 2, 3],
            };
            let ok = matches!(outcome, Outcome::Code(c) if allowed.contains(&c));
            if !ok || (outcome == Outcome::Code(2) && !message.contains("bad.h5")) {
                let keep = dir.join(format!("failed_{}_{case}.h5", kind.name.replace(' ', "_")));
                let _ = std::fs::copy(&file, &keep);
                failures.push(format!(
                    "{} case {case} ({cmd}): {outcome:?}: {message} (kept as {})",
                    kind.name,
                    keep.display()
                ));
            }
            // How the child process that reads an unchecked file ended.
            let child = if message.contains("crashed the HDF5 library") {
                "child crashed"
            } else if message.contains("did not finish reading") {
                "child timed out"
            } else {
                ""
            };
            let child = if child.is_empty() { note } else { child };
            let key = match outcome {
                Outcome::Code(c) if !child.is_empty() => format!("exit {c} ({child})"),
                Outcome::Code(c) => format!("exit {c}"),
                other => format!("{other:?}"),
            };
            *tally
                .entry((kind.name.clone(), cmd))
                .or_default()
                .entry(key)
                .or_default() += 1;
        };
        // In this process: the checksums are verified, and a file without them refused, before
        // HDF5 sees the file.
        match mpm_cli::info::info(&file, true, Verify::Required) {
            Ok(_) => record("info", Outcome::Code(0), "", ""),
            Err(e) => record("info", Outcome::Code(e.exit_code()), &e.to_string(), ""),
        }
        if !kind.block {
            // What `mpm-cli --unchecked info` reads, in this process (the child is mpm-cli):
            // a signal here would end the test.
            let limit = Some(Duration::from_secs_f64(
                CHILD_TIMEOUT_S.parse().expect("seconds"),
            ));
            let read = Checked::open_with(&file, Verify::Unchecked, Path::new(bin()), limit)
                .and_then(|c| Ok((c.read_file()?, c.read_layout()?)));
            match read {
                Ok(_) => record("--unchecked read", Outcome::Code(0), "", ""),
                Err(e) => record("--unchecked read", Outcome::Code(2), &e.to_string(), ""),
            }
        }
        if kind.checkpoint && case % RESUME_EVERY == 0 {
            let resume = ["run", &scene, "--out", &out, "--quiet", "--resume", &f];
            let (o, e) = run(&resume, dir);
            record("resume", o, &e, "");
            if !kind.block {
                let mut args = vec!["--unchecked"];
                args.extend_from_slice(&resume);
                let (o, e) = run(&args, dir);
                // Damage the checksums would have caught may change the results unnoticed:
                // counted, and the reason the option is unsafe.
                let note = match o {
                    Outcome::Code(0) if outputs(Path::new(&out)) == kind.reference => {
                        "same results"
                    }
                    Outcome::Code(0) => "different results",
                    _ => "",
                };
                record("--unchecked resume", o, &e, note);
            }
        }
    }
    (tally, failures)
}

#[test]
fn damaged_files_of_every_kind_never_crash_hang_or_pass_unchecked() {
    let started = Instant::now();
    let d = tmpdir("damaged-files");
    let mut kinds = Vec::new();
    for (family, text, ckpt) in [
        ("explicit", SNOW_2D, "ckpt_000025.h5"),
        ("tlmpm", TLMPM_SNOW_2D, "ckpt_000030.h5"),
        ("diq", DIQ_2D, "ckpt_000030.h5"),
    ] {
        let scene = write(&d, &format!("{family}.toml"), text);
        let out = run_scene(&d, &format!("{family}-run.toml"), text);
        for (what, file) in [("snapshot", "snap_000001.h5"), ("checkpoint", ckpt)] {
            let bytes = std::fs::read(out.join(file)).expect("output file");
            let block = u64::from_le_bytes(bytes[16..24].try_into().expect("8 bytes")) as usize;
            assert!(block >= 512 && block.is_power_of_two(), "{family} {what}");
            for (with, b) in [(true, bytes.clone()), (false, bytes[block..].to_vec())] {
                kinds.push(Kind {
                    name: format!(
                        "{family} {what} {}",
                        if with { "with block" } else { "without block" }
                    ),
                    bytes: b,
                    scene: scene.clone(),
                    checkpoint: what == "checkpoint",
                    block: with,
                    reference: Vec::new(),
                });
            }
        }
    }
    // The intact copies: checked files read, files without the block are refused unless
    // --unchecked, and read with it.
    let probe = d.join("intact");
    std::fs::create_dir_all(&probe).expect("dir");
    for k in &mut kinds {
        let file = probe.join("intact.h5");
        std::fs::write(&file, &k.bytes).expect("write");
        let f = file.to_string_lossy().into_owned();
        let (o, e) = run(&["info", &f], &probe);
        let expected = if k.block { 0 } else { 2 };
        assert_eq!(o, Outcome::Code(expected), "{}: {e}", k.name);
        if !k.block {
            assert!(
                e.contains("no checksum block") && e.contains("--unchecked"),
                "{e}"
            );
            let (o, e) = run(&["--unchecked", "info", &f], &probe);
            assert_eq!(o, Outcome::Code(0), "{}: {e}", k.name);
        }
        if k.checkpoint {
            // Resumed from the intact file (unchecked when it has no block): the same outputs
            // with and without the block.
            let out = probe.join(&k.name);
            let (scene, o) = (k.scene.to_string_lossy(), out.to_string_lossy());
            let mut args = vec!["run", &scene, "--out", &o, "--quiet", "--resume", &f];
            if !k.block {
                args.insert(0, "--unchecked");
            }
            let (code, e) = run(&args, &probe);
            assert_eq!(code, Outcome::Code(0), "{}: {e}", k.name);
            k.reference = outputs(&out);
            assert!(
                k.reference.len() >= 2,
                "{}: the resume wrote outputs",
                k.name
            );
        }
    }
    for pair in kinds.chunks(2) {
        if let [with, without] = pair {
            assert_eq!(with.reference, without.reference, "{}", without.name);
        }
    }
    // Two workers, each on every other kind.
    let results: Vec<(Tally, Vec<String>)> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..2)
            .map(|w| {
                let (kinds, d) = (&kinds, &d);
                s.spawn(move || {
                    let dir = d.join(format!("worker{w}"));
                    std::fs::create_dir_all(&dir).expect("dir");
                    let mut tally = Tally::new();
                    let mut failures = Vec::new();
                    for (i, k) in kinds.iter().enumerate().filter(|(i, _)| i % 2 == w) {
                        let (t, f) = fuzz(k, &dir, 0x5eed_0000 + i as u64);
                        tally.extend(t);
                        failures.extend(f);
                    }
                    (tally, failures)
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("worker"))
            .collect()
    });
    let mut failures = Vec::new();
    eprintln!("{VARIANTS} damaged copies per kind; outcomes per command:");
    for (tally, f) in results {
        for ((kind, cmd), counts) in tally {
            let line: Vec<String> = counts
                .iter()
                .filter(|(o, _)| *o != "seconds")
                .map(|(o, n)| format!("{o}: {n}"))
                .collect();
            let seconds = counts.get("seconds").copied().unwrap_or(0) as f64 * 1e-6;
            eprintln!(
                "  {kind:<34} {cmd:<20} {} ({seconds:.1} s)",
                line.join(", ")
            );
        }
        failures.extend(f);
    }
    eprintln!("{:.1} s", started.elapsed().as_secs_f64());
    assert!(
        failures.is_empty(),
        "{} violations:\n{}",
        failures.len(),
        failures.join("\n")
    );
}
