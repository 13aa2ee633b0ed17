//! Fuzz test: checkpoints with damaged bytes never crash or hang `mpm-cli run --resume` or
//! `mpm-cli info`. Every damage to a dataset's values exits 2 naming the file and the dataset;
//! any exit 0 (damage the file's checksums could not see) must give results bitwise identical
//! to the undamaged checkpoint's.

mod common;

use common::*;
use mpm_io::{read_file, Data};
use std::time::{Duration, Instant};

/// How long one command may take before it counts as a hang (an undamaged resume takes well
/// under a second).
const TIMEOUT: Duration = Duration::from_secs(20);

/// The byte range of each dataset's values in `bytes`, for the datasets whose values occur
/// exactly once in the file (found by their little-endian bytes).
fn payloads(bytes: &[u8], ck: &mpm_io::Snapshot) -> Vec<(String, std::ops::Range<usize>)> {
    let mut out = Vec::new();
    for f in &ck.fields {
        let raw: Vec<u8> = match &f.data {
            Data::F64 { values, .. } => values.iter().flat_map(|v| v.to_le_bytes()).collect(),
            Data::U32 { values, .. } => values.iter().flat_map(|v| v.to_le_bytes()).collect(),
        };
        let at: Vec<usize> = (0..=bytes.len() - raw.len())
            .filter(|&i| bytes[i..i + raw.len()] == raw[..])
            .collect();
        if let [i] = at[..] {
            out.push((format!("/particles/{}", f.name), i..i + raw.len()));
        }
    }
    out
}

#[test]
fn damaged_checkpoints_never_crash_or_hang_and_are_detected() {
    let started = Instant::now();
    let d = tmpdir("damaged-checkpoints");
    let scene = write(&d, "snow.toml", SNOW_2D);
    let scene = scene.to_string_lossy().into_owned();
    let out = d.join("out");
    let o = cli(&["run", &scene, "--out", &out.to_string_lossy(), "--quiet"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let good_path = out.join("ckpt_000025.h5");
    let good = std::fs::read(&good_path).expect("checkpoint");
    let ck = read_file(&good_path).expect("undamaged checkpoint");
    let ranges = payloads(&good, &ck);
    for name in ["x", "v", "F", "affine"] {
        assert!(
            ranges
                .iter()
                .any(|(n, _)| *n == format!("/particles/{name}")),
            "the values of {name} are located"
        );
    }

    // The undamaged references.
    let bad = d.join("bad.h5");
    let bad_s = bad.to_string_lossy().into_owned();
    let resumed = d.join("resumed");
    let resumed_s = resumed.to_string_lossy().into_owned();
    let resume_args = [
        "run",
        scene.as_str(),
        "--out",
        resumed_s.as_str(),
        "--quiet",
        "--resume",
        bad_s.as_str(),
    ];
    std::fs::write(&bad, &good).expect("write");
    let (o, _, e) = run_with_timeout(&resume_args, &[], &d, TIMEOUT);
    assert!(matches!(o, Outcome::Code(0)), "undamaged resume: {e}");
    let reference_outputs = outputs(&resumed);
    assert!(reference_outputs.len() >= 2, "the resume wrote its outputs");
    let (o, reference_info, e) = run_with_timeout(&["info", &bad_s], &[], &d, TIMEOUT);
    assert!(matches!(o, Outcome::Code(0)), "undamaged info: {e}");

    let mut rng = Rng(0xdead_c0de);
    let cases = 300;
    let (mut crashes, mut hangs, mut detected, mut harmless) = (0, 0, 0, 0);
    let (mut payload_cases, mut payload_detected) = (0, 0);
    let mut failures = Vec::new();
    for case in 0..cases {
        // Half of the cases damage a dataset's values, half any byte of the file; a third of
        // them overwrite 8 bytes instead of one.
        let mut b = good.clone();
        let target = if case % 2 == 0 {
            let (name, r) = &ranges[rng.below(ranges.len())];
            Some((name.clone(), r.start + rng.below(r.len())))
        } else {
            None
        };
        let at = target.as_ref().map_or(rng.below(b.len()), |(_, i)| *i);
        let width = if case % 3 == 0 {
            8.min(b.len() - at)
        } else {
            1
        };
        for byte in &mut b[at..at + width] {
            *byte ^= 1 + rng.below(255) as u8;
        }
        std::fs::write(&bad, &b).expect("write damaged checkpoint");
        let _ = std::fs::remove_dir_all(&resumed);
        for (cmd, args) in [
            ("info", &["info", bad_s.as_str()][..]),
            ("resume", &resume_args[..]),
        ] {
            let what = format!("case {case} ({cmd}, {width} bytes at {at})");
            let (outcome, stdout, stderr) = run_with_timeout(args, &[], &d, TIMEOUT);
            match outcome {
                Outcome::Signal => {
                    crashes += 1;
                    failures.push(format!("{what}: killed by a signal; {stderr}"));
                }
                Outcome::Hang => {
                    hangs += 1;
                    failures.push(format!("{what}: still running after {TIMEOUT:?}"));
                }
                Outcome::Code(2) => {
                    detected += 1;
                    if !stderr.contains("bad.h5") {
                        failures.push(format!("{what}: message does not name the file: {stderr}"));
                    }
                    if let Some((name, _)) = &target {
                        payload_cases += 1;
                        if stderr.contains(&format!("dataset {name} ")) {
                            payload_detected += 1;
                        } else {
                            failures
                                .push(format!("{what}: message does not name {name}: {stderr}"));
                        }
                    }
                }
                Outcome::Code(0) => {
                    harmless += 1;
                    let same = if cmd == "info" {
                        stdout == reference_info
                    } else {
                        outputs(&resumed) == reference_outputs
                    };
                    if target.is_some() || !same {
                        failures.push(format!(
                            "{what}: exit 0 from a damaged checkpoint{}",
                            if same { "" } else { " with different results" }
                        ));
                    }
                }
                Outcome::Code(c) => {
                    crashes += 1;
                    failures.push(format!("{what}: exit code {c}; {stderr}"));
                }
            }
        }
    }
    eprintln!(
        "{cases} damaged checkpoints × (info, resume): {crashes} crashes, {hangs} hangs, \
         {detected} refused with exit 2, {harmless} harmless exit 0; {payload_detected} of \
         {payload_cases} runs on damaged dataset values named the dataset; {:.1} s",
        started.elapsed().as_secs_f64()
    );
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    assert_eq!((crashes, hangs), (0, 0));
    assert_eq!((payload_cases, payload_detected), (cases, cases));
}
