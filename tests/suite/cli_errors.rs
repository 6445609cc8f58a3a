//! A bad study file exits with status 2 and one message that names
//! the file, the key (and line) and the reason; no output file is created or changed. And
//! an existing output directory survives an interrupted run untouched.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use super::common::*;

struct Case {
    name: &'static str,
    study: String,
    key: &'static str,
    line: Option<usize>,
    reason: &'static str,
}

fn line_of(text: &str, needle: &str) -> usize {
    text.lines().position(|l| l.starts_with(needle)).unwrap() + 1
}

fn cases() -> Vec<Case> {
    let t = study_text("thesis.toml");
    let set = |k: &str, v: &str| set_key(&t, k, v);
    vec![
        Case {
            name: "syntax error",
            study: set("mass", "= 1800.0"),
            key: "vehicle.mass",
            line: Some(line_of(&t, "mass =")),
            reason: "TOML syntax error",
        },
        Case {
            name: "unknown key",
            study: t.replace("wheel_radius = 0.3", "wheel_radius = 0.3\nwheel_count = 4"),
            key: "vehicle.wheel_count",
            line: Some(line_of(&t, "wheel_radius") + 1),
            reason: "unknown field `wheel_count`",
        },
        Case {
            name: "missing required key",
            study: t
                .lines()
                .filter(|l| !l.starts_with("gravity"))
                .collect::<Vec<_>>()
                .join("\n"),
            key: "vehicle.gravity",
            line: Some(line_of(&t, "[vehicle]")),
            reason: "required key is missing",
        },
        // A top-level key missing is named alone, not as a key of the first table.
        Case {
            name: "missing top-level name",
            study: t
                .lines()
                .filter(|l| !l.starts_with("name ="))
                .collect::<Vec<_>>()
                .join("\n"),
            key: "name",
            line: None,
            reason: "required key is missing",
        },
        Case {
            name: "missing top-level seed",
            study: t
                .lines()
                .filter(|l| !l.starts_with("seed ="))
                .collect::<Vec<_>>()
                .join("\n"),
            key: "seed",
            line: None,
            reason: "required key is missing",
        },
        Case {
            name: "missing top-level realisations",
            study: t
                .lines()
                .filter(|l| !l.starts_with("realisations ="))
                .collect::<Vec<_>>()
                .join("\n"),
            key: "realisations",
            line: None,
            reason: "required key is missing",
        },
        // An unknown key's list names every key the table has, not only the drive mode's.
        Case {
            name: "unknown key lists all keys of drive",
            study: t.replace("[drive]", "[drive]\nbogus = 1"),
            key: "drive.bogus",
            line: Some(line_of(&t, "[drive]") + 1),
            reason: "expected one of [\"mode\", \"min_speed\", \"exclude_braking\", \"durations\", \"duration\"",
        },
        // A key of another table says where it belongs.
        Case {
            name: "a drive key under terrain",
            study: t.replace("[terrain]", "[terrain]\nexclude_braking = true"),
            key: "terrain.exclude_braking",
            line: Some(line_of(&t, "[terrain]") + 1),
            reason: "unknown field `exclude_braking` in [terrain]: it belongs in [drive]",
        },
        Case {
            name: "a drive key under vehicle",
            study: t.replace("[vehicle]", "[vehicle]\nmin_speed = 1.0"),
            key: "vehicle.min_speed",
            line: Some(line_of(&t, "[vehicle]") + 1),
            reason: "unknown field `min_speed` in [vehicle]: it belongs in [drive]",
        },
        Case {
            name: "another profile's key",
            study: t.replace("[terrain]", "[terrain]\nfile = \"x.csv\""),
            key: "terrain.file",
            line: Some(line_of(&t, "[terrain]") + 1),
            reason: "it is a key of profile \"file\", and this [terrain] is profile \"cos2\"",
        },
        Case {
            name: "wrong type",
            study: set("mass", "\"heavy\""),
            key: "vehicle.mass",
            line: Some(line_of(&t, "mass =")),
            reason: "invalid type: string",
        },
        Case {
            name: "mass <= 0",
            study: set("mass", "-1800.0"),
            key: "vehicle.mass",
            line: Some(line_of(&t, "mass =")),
            reason: "must be > 0, got -1800",
        },
        Case {
            name: "time_step <= 0",
            study: set("time_step", "0.0"),
            key: "drive.time_step",
            line: Some(line_of(&t, "time_step =")),
            reason: "must be > 0",
        },
        Case {
            name: "duration not a multiple of time_step",
            study: set("duration", "600.005"),
            key: "drive.duration",
            line: Some(line_of(&t, "duration =")),
            reason: "whole multiple of drive.time_step",
        },
        Case {
            name: "unknown drive mode",
            study: t.replace("[drive]", "[drive]\nmode = \"playback\""),
            key: "drive.mode",
            line: Some(line_of(&t, "[drive]") + 1),
            reason: "unknown drive mode \"playback\"; expected one of [\"torque\", \"speed_trace\", \"replay\", \"coastdown\", \"designed\"]",
        },
        Case {
            name: "a key the drive mode does not have",
            study: t.replace("[drive]", "[drive]\ntorque_peak = 300.0"),
            key: "drive.torque_peak",
            line: Some(line_of(&t, "[drive]") + 1),
            reason: "unknown field `torque_peak`",
        },
        Case {
            name: "an unknown noise channel",
            study: t.replace("[noise]", "[noise]\nwind_sd = [1.0]"),
            key: "noise.wind_sd",
            line: Some(line_of(&t, "[noise]") + 1),
            reason: "unknown field `wind_sd`",
        },
        Case {
            name: "negative sigma",
            study: set("velocity_sd", "[1.0, -0.5]"),
            key: "noise.velocity_sd[1]",
            line: Some(line_of(&t, "velocity_sd =")),
            reason: "must be >= 0, got -0.5",
        },
        Case {
            name: "realisations = 0",
            study: set("realisations", "0"),
            key: "realisations",
            line: Some(line_of(&t, "realisations =")),
            reason: "must be at least 1",
        },
        Case {
            name: "empty scales",
            study: set("scales", "[]"),
            key: "terrain.scales",
            line: Some(line_of(&t, "scales =")),
            reason: "at least one value",
        },
        Case {
            name: "non-finite number",
            study: set("height", "nan"),
            key: "terrain.height",
            line: Some(line_of(&t, "height =")),
            reason: "must be a finite number",
        },
        Case {
            // With 60 N·m instead of 225, the hills of scale 2 are too steep to climb.
            name: "a scale at which the vehicle stalls",
            study: set_key(&set("scales", "[1.0, 2.0]"), "torque_mean", "60.0"),
            key: "terrain.scales[1]",
            line: Some(line_of(&t, "scales =")),
            reason: "the vehicle stalls",
        },
    ]
}

fn run_cli(study: &Path, out: &Path, extra: &[&str]) -> (i32, String, String) {
    let mut args = vec![
        "run".as_ref(),
        study.as_os_str(),
        "--out".as_ref(),
        out.as_os_str(),
    ];
    args.push("--quiet".as_ref());
    args.extend(extra.iter().map(|a| std::ffi::OsStr::new(*a)));
    cli(&args, Path::new("."))
}

/// Every regular file in `dir` with its bytes, but the lock (which records the pid of the
/// last process that wrote the directory).
fn snapshot(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap())
        .filter(|e| e.path().is_file() && e.file_name() != chassis_mc::output::lock::LOCK)
        .map(|e| {
            (
                e.file_name().to_string_lossy().into_owned(),
                std::fs::read(e.path()).unwrap(),
            )
        })
        .collect();
    files.sort();
    files
}

#[test]
fn bad_study_files_exit_2_with_file_key_line_and_reason() {
    let tmp = tempfile::tempdir().unwrap();
    // An existing results directory that no failed run may touch.
    let existing = tmp.path().join("existing");
    let (code, _, err) = run_cli(
        &study_path("thesis.toml"),
        &existing,
        &["--realisations", "3"],
    );
    assert_eq!(code, 0, "{err}");
    let before = snapshot(&existing);
    assert_eq!(before.len(), 5, "three tables, the report and the manifest");

    for case in cases() {
        let file = tmp
            .path()
            .join(format!("{}.toml", case.name.replace(' ', "_")));
        std::fs::write(&file, &case.study).unwrap();
        let fresh = tmp
            .path()
            .join(format!("out-{}", case.name.replace(' ', "_")));
        for out in [&fresh, &existing] {
            let (code, stdout, stderr) = run_cli(&file, out, &[]);
            assert_eq!(code, 2, "{}: exit {code}, stderr: {stderr}", case.name);
            assert!(stdout.is_empty(), "{}: {stdout}", case.name);
            let message = stderr.trim();
            assert_eq!(
                message.lines().count(),
                1,
                "{}: one line: {message}",
                case.name
            );
            assert!(
                message.contains(&file.display().to_string()),
                "{}: file: {message}",
                case.name
            );
            assert!(
                message.contains(&format!("`{}`", case.key)),
                "{}: key: {message}",
                case.name
            );
            if let Some(line) = case.line {
                assert!(
                    message.contains(&format!("line {line}")),
                    "{}: line: {message}",
                    case.name
                );
            }
            assert!(
                message.contains(case.reason),
                "{}: reason: {message}",
                case.name
            );
        }
        assert!(
            !fresh.exists(),
            "{}: created {}",
            case.name,
            fresh.display()
        );
        assert_eq!(
            snapshot(&existing),
            before,
            "{}: changed existing output",
            case.name
        );
    }
}

#[test]
fn bad_arguments_exit_2() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    for extra in [
        &["--realisations", "0"][..],
        &["--threads", "0"],
        &["--seed", "-1"],
        &["--seed", "9223372036854775808"],
        &["--bogus"],
    ] {
        let (code, _, stderr) = run_cli(&study_path("thesis.toml"), &out, extra);
        assert_eq!(code, 2, "{extra:?}: {stderr}");
        assert!(!out.exists());
    }
    let (code, _, stderr) = run_cli(&tmp.path().join("nope.toml"), &out, &[]);
    assert_eq!(code, 2, "{stderr}");
    assert!(
        stderr.contains("nope.toml") && stderr.contains("cannot read"),
        "{stderr}"
    );
}

#[test]
fn an_interrupted_run_leaves_existing_results_untouched() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let (code, _, err) = run_cli(&study_path("thesis.toml"), &out, &["--realisations", "3"]);
    assert_eq!(code, 0, "{err}");
    let before = snapshot(&out);

    // A long run into the same directory, killed (SIGKILL) once it has started writing.
    let mut child = Command::new(bin())
        .args([
            "run",
            "--quiet",
            "--threads",
            "1",
            "--realisations",
            "100000",
            "--out",
        ])
        .arg(&out)
        .arg(study_path("thesis.toml"))
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let started = Instant::now();
    // Started writing: the staging directory holds a part or a part being written.
    let staging = out.join(chassis_mc::run::STAGING);
    let writing = || std::fs::read_dir(&staging).is_ok_and(|mut d| d.next().is_some());
    while !writing() && started.elapsed() < Duration::from_secs(60) {
        std::thread::sleep(Duration::from_millis(20));
    }
    assert!(writing(), "the run never started writing");
    std::thread::sleep(Duration::from_millis(300));
    child.kill().unwrap();
    child.wait().unwrap();

    let after: Vec<_> = snapshot(&out)
        .into_iter()
        .filter(|(name, _)| !name.contains(".tmp-"))
        .collect();
    assert_eq!(
        after, before,
        "committed files changed by an interrupted run"
    );
}

/// A terrain scale at which a grade reaches 0.5 rad in magnitude is exit 2 naming
/// `terrain.scales[i]` and its line, and nothing is written.
///
/// Regression: a non-physical grade was accepted and run.
#[test]
fn a_grade_of_half_a_radian_or_more_is_a_study_error() {
    // Scaled by 1000, the grade reaches ±83 rad, which sin and cos wrap into plausible
    // numbers; scaled geometrically by 9, the steepest grade is atan(9 × 0.083) = 0.64 rad.
    let tmp = tempfile::tempdir().unwrap();
    let t = study_text("thesis.toml");
    for (name, text) in [
        ("grade", set_key(&t, "scales", "[1.0, 1000.0]")),
        (
            "elevation",
            set_key(
                &set_key(&t, "scales", "[1.0, 9.0]"),
                "scale_applies_to",
                "\"elevation\"",
            ),
        ),
    ] {
        let file = tmp.path().join(format!("{name}.toml"));
        std::fs::write(&file, &text).unwrap();
        let out = tmp.path().join(format!("out-{name}"));
        let (code, _, stderr) = run_cli(&file, &out, &[]);
        assert_eq!(code, 2, "{name}: {stderr}");
        assert!(
            stderr.contains("`terrain.scales[1]`")
                && stderr.contains(&format!("line {}", line_of(&t, "scales =")))
                && stderr.contains("below 0.5 rad"),
            "{name}: {stderr}"
        );
        assert!(!out.exists(), "{name}: nothing is written");
    }
}

/// `--out` (or `figures`' directory) naming a file, or a path under a file, exits 2 with one
/// message naming it, and leaves the file as it was.
///
/// Regression: it exited 1 and printed the message twice.
#[test]
fn out_naming_a_file_exits_2_with_one_message() {
    let tmp = tempfile::tempdir().unwrap();
    let file = tmp.path().join("results.txt");
    std::fs::write(&file, b"mine").unwrap();
    let study = study_path("thesis.toml");
    for args in [
        vec![
            "run".as_ref(),
            study.as_os_str(),
            "--out".as_ref(),
            file.as_os_str(),
        ],
        vec![
            "summarize".as_ref(),
            tmp.path().as_os_str(),
            "--out".as_ref(),
            file.as_os_str(),
        ],
        vec!["figures".as_ref(), file.as_os_str()],
        vec![
            "run".as_ref(),
            study.as_os_str(),
            "--out".as_ref(),
            file.join("sub").into_os_string().leak(),
        ],
    ] {
        let (code, _, stderr) = cli(&args, tmp.path());
        assert_eq!(code, 2, "{args:?}: {stderr}");
        assert_eq!(
            stderr.trim().lines().count(),
            1,
            "{args:?}: one message: {stderr}"
        );
        assert!(stderr.contains("results.txt"), "{stderr}");
    }
    assert_eq!(std::fs::read(&file).unwrap(), b"mine");
}

/// A `--shard K/N` that holds none of the realisations is exit 2 naming the shard and the
/// largest N, and nothing is written.
///
/// Regression: an empty shard was accepted.
#[test]
fn a_shard_holding_no_realisation_exits_2() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    // ⌊2·100/200⌋ = ⌊3·100/200⌋ = 1: shard 2 of 200 holds no realisation.
    let (code, _, stderr) = run_cli(
        &study_path("thesis.toml"),
        &out,
        &["--realisations", "100", "--shard", "2/200"],
    );
    assert_eq!(code, 2, "{stderr}");
    assert!(
        stderr.contains("2/200") && stderr.contains("N <= 100"),
        "{stderr}"
    );
    assert!(!out.exists());
}

#[test]
fn check_lists_the_conditions_and_estimates_without_writing() {
    let tmp = tempfile::tempdir().unwrap();
    let study = study_path("thesis.toml");
    let (code, stdout, stderr) = cli(
        &[
            "check".as_ref(),
            study.as_os_str(),
            "--realisations".as_ref(),
            "5000".as_ref(),
        ],
        tmp.path(),
    );
    assert_eq!(code, 0, "{stderr}");
    assert!(
        stdout.contains("11 conditions × 5000 realisations = 55000"),
        "{stdout}"
    );
    assert!(stdout.contains("estimated run time") && stdout.contains("estimated output"));
    assert_eq!(
        std::fs::read_dir(tmp.path()).unwrap().count(),
        0,
        "check writes nothing"
    );
    let bad = tmp.path().join("bad.toml");
    std::fs::write(&bad, set_key(&study_text("thesis.toml"), "mass", "-1.0")).unwrap();
    let (code, _, stderr) = cli(&["check".as_ref(), bad.as_os_str()], tmp.path());
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("`vehicle.mass`"), "{stderr}");
}

#[test]
fn progress_reaches_a_log_file_when_stderr_is_not_a_terminal() {
    // stderr is a pipe here, as under SLURM or nohup: a plain line, not a bar that only
    // appears at the end.
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let output = Command::new(bin())
        .args(["run", "--no-figures", "--realisations", "50", "--out"])
        .arg(&out)
        .arg(study_path("thesis.toml"))
        .output()
        .unwrap();
    assert!(output.status.success());
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.contains("progress: 550/550 realisations (100.0 %)") && !stderr.contains('\r'),
        "{stderr}"
    );
}

#[test]
fn one_number_stands_for_a_list_of_one_wherever_a_list_is_meant() {
    // Axes (noise levels, scales, durations) and the estimator list: a bare value is the
    // same study, identity included, as the list of that value.
    let t = study_text("thesis.toml");
    let lists = set_key(
        &set_key(&set_key(&t, "scales", "[1.0]"), "velocity_sd", "[1.0]"),
        "estimators",
        "[\"ols\"]",
    )
    .replace("[drive]", "[drive]\ndurations = [60.0]");
    let bare = set_key(
        &set_key(&set_key(&t, "scales", "1"), "velocity_sd", "1.0"),
        "estimators",
        "\"ols\"",
    )
    .replace("[drive]", "[drive]\ndurations = 60");
    let a = chassis_mc::study::Study::from_toml(&lists, "lists.toml").unwrap();
    let b = chassis_mc::study::Study::from_toml(&bare, "bare.toml").unwrap();
    assert_eq!(a.to_toml(), b.to_toml());
    assert_eq!(a.identity(), b.identity());
    // Likewise a `[truth]` key: `1` is `[1.0]`, and a key at its neutral value alone (or
    // the default air speed) is the key absent, so a resume finds the same study.
    let truth = |table: &str| {
        let text = format!(
            "{lists}
[truth]
{table}
"
        );
        chassis_mc::study::Study::from_toml(&text, "truth.toml").unwrap()
    };
    assert_eq!(
        truth(
            "wind_speed = 1
mass_rate = -0.001"
        )
        .to_toml(),
        truth(
            "wind_speed = [1.0]
mass_rate = -0.001
force_scale = [0.0]"
        )
        .to_toml()
    );
    let plain = chassis_mc::study::Study::from_toml(&lists, "lists.toml").unwrap();
    let neutral = truth(
        "wind_speed = [0]
air_density_ratio = 1",
    );
    assert_eq!(neutral.to_toml(), plain.to_toml());
    assert_eq!(neutral.identity(), plain.identity());
    let ground = chassis_mc::study::Study::from_toml(
        &set_key(&lists, "estimators", "[\"ols\"]\nair_speed = \"ground\""),
        "ground.toml",
    )
    .unwrap();
    assert_eq!(ground.to_toml(), plain.to_toml());
    // A value listed twice would be two identical conditions: refused, naming the repeat.
    let twice = chassis_mc::study::Study::from_toml(
        &format!("{lists}\n[truth]\nwind_speed = [0.0, 0.0]\n"),
        "truth.toml",
    )
    .unwrap_err();
    assert_eq!(twice.key.as_deref(), Some("truth.wind_speed[1]"), "{twice}");
    // A value of the wrong type still names the key.
    let wrong = set_key(&t, "velocity_sd", "\"fast\"");
    let err = chassis_mc::study::Study::from_toml(&wrong, "wrong.toml").unwrap_err();
    assert_eq!(err.key.as_deref(), Some("noise.velocity_sd"), "{err}");
}
