//! `nrslam scene --random` writes a scene file that regenerates byte for byte from its seed, and
//! a launch file runs it with `scene:=FILE`, the relative path taken from the current directory.

mod common;
use common::*;

/// How many targets the evaluator scored in each row of metrics.csv. ET-GOPSA (c = 5, α = 2)
/// gives each true target 4 slots, each filled by one estimate point or missed at c/α = 2.5,
/// and charges every unassigned estimate point 2.5: so 4 N = points − false/2.5 + missed/2.5.
fn targets_scored(metrics_csv: &str) -> Vec<f64> {
    let mut lines = metrics_csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let column = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (points, missed, false_) = (
        column("estimate_points"),
        column("etgospa_missed"),
        column("etgospa_false"),
    );
    lines
        .map(|line| {
            let row: Vec<f64> = line.split(',').map(|v| v.parse().unwrap()).collect();
            (row[points] - row[false_] / 2.5 + row[missed] / 2.5) / 4.0
        })
        .collect()
}

#[test]
fn random_scene_is_written_reproducibly_and_launched_from_the_current_directory() {
    let work = temp();
    let scene_args = [
        "scene",
        "--random",
        "--seed",
        "5",
        "--laps",
        "1",
        "--targets",
        "7",
        "--out",
        "scenes/s5.toml",
    ];
    let with_png = [&scene_args[..], &["--png", "scenes/s5.png"]].concat();
    let output = run_ok_in(work.path(), &with_png);
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        stdout.starts_with("wrote scenes/s5.toml: 7 targets") && stdout.contains("1 lap"),
        "{stdout}"
    );
    let file = work.path().join("scenes/s5.toml");
    let text = read(&file);
    assert!(
        text.contains(
            "#   nrslam scene --random --seed 5 --laps 1 --targets 7 --out scenes/s5.toml"
        ),
        "{text}"
    );
    assert!(work.path().join("scenes/s5.png").metadata().unwrap().len() > 1000);

    // The same command elsewhere writes the same bytes; another seed, another scene.
    let again = temp();
    run_ok_in(again.path(), &scene_args);
    assert_eq!(read(&again.path().join("scenes/s5.toml")), text);
    let mut other_seed = scene_args;
    other_seed[3] = "6";
    run_ok_in(again.path(), &other_seed);
    assert_ne!(read(&again.path().join("scenes/s5.toml")), text);

    // The launch file lives in the repository; the scene path is relative to `work`.
    let launch = root().join("launch/paper-ideal.toml");
    run_ok_in(
        work.path(),
        &[
            "launch",
            launch.to_str().unwrap(),
            "scene:=scenes/s5.toml",
            "frames:=20",
            "--out",
            "run",
        ],
    );
    let run = work.path().join("run");
    let summary = summary(&run);
    assert_eq!(summary["frames"], 20);
    // The record keeps the path as typed, not the absolute one.
    assert_eq!(summary["arguments"]["scene"], "scenes/s5.toml");
    // The evaluator scored the random scene's 7 targets, not the hall's 10.
    let scored = targets_scored(&read(&run.join("metrics.csv")));
    assert_eq!(scored.len(), 20);
    for n in scored {
        assert!((n - 7.0).abs() < 1e-9, "{n} targets scored");
    }

    // A scene path that does not exist is named in the error, resolved from `work`.
    let output = nrslam()
        .current_dir(work.path())
        .args([
            "launch",
            launch.to_str().unwrap(),
            "scene:=scenes/missing.toml",
            "frames:=2",
            "--out",
            "run2",
        ])
        .output()
        .unwrap();
    assert!(!output.status.success());
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.contains(&format!(
            "{}",
            work.path().join("scenes/missing.toml").display()
        )),
        "{stderr}"
    );
}

#[test]
fn scene_flags_are_checked() {
    let work = temp();
    let out = work.path().join("s.toml");
    let out = out.to_str().unwrap();
    for (args, expected) in [
        (vec!["scene", "--seed", "1", "--out", out], "--random"),
        (
            vec!["scene", "--random", "--laps", "4", "--out", out],
            "laps[0]",
        ),
        (
            vec!["scene", "--random", "--targets", "9:6", "--out", out],
            "targets",
        ),
        (
            vec!["scene", "--random", "--laps", "x", "--out", out],
            "--laps",
        ),
    ] {
        let output = run(&args);
        assert!(!output.status.success(), "{args:?}");
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(stderr.contains(expected), "{args:?}: {stderr}");
        assert_eq!(stderr.lines().count(), 1, "one line: {stderr}");
    }
    assert!(!work.path().join("s.toml").exists());
}

#[test]
fn agvs_and_stations_are_added_without_changing_the_scene() {
    let work = temp();
    let base = [
        "scene",
        "--random",
        "--seed",
        "8",
        "--laps",
        "1",
        "--targets",
        "6",
    ];
    run_ok_in(work.path(), &[&base[..], &["--out", "one.toml"]].concat());
    run_ok_in(
        work.path(),
        &[
            &base[..],
            &["--agvs", "1", "--stations", "0", "--out", "same.toml"],
        ]
        .concat(),
    );
    let output = run_ok_in(
        work.path(),
        &[
            &base[..],
            &[
                "--agvs",
                "3",
                "--stations",
                "2",
                "--out",
                "multi.toml",
                "--png",
                "multi.png",
            ],
        ]
        .concat(),
    );
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        stdout.starts_with("wrote multi.toml: 6 targets")
            && stdout
                .trim_end()
                .ends_with("3 AGVs on the loop, 2 stations on the walls"),
        "{stdout}"
    );
    let body = |name: &str| -> String {
        read(&work.path().join(name))
            .lines()
            .filter(|line| !line.starts_with('#'))
            .collect::<Vec<_>>()
            .join("\n")
    };
    // --agvs 1 --stations 0 is the scene without them, to the byte.
    assert_eq!(body("same.toml"), body("one.toml"));
    let one = body("one.toml");
    assert!(one.contains("[trajectory]") && !one.contains("[[agv]]"));
    let multi = read(&work.path().join("multi.toml"));
    assert!(
        multi.contains("--agvs 3 --stations 2 --out multi.toml"),
        "{multi}"
    );
    assert!(
        multi.contains("#   agvs = 3\n#   stations = 2\n"),
        "{multi}"
    );
    let body_multi = body("multi.toml");
    assert_eq!(body_multi.matches("[[agv]]").count(), 3);
    assert_eq!(body_multi.matches("[[station]]").count(), 2);
    assert!(!body_multi.contains("\n[trajectory]"));
    // The targets and the hall are those of the one-AGV scene.
    let targets = |text: &str| text[text.find("[[targets]]").unwrap()..].to_owned();
    assert_eq!(targets(&body_multi), targets(&one));
    assert!(work.path().join("multi.png").metadata().unwrap().len() > 1000);

    // A launch file runs it as before (agv1 is the default sensor).
    let launch = root().join("launch/paper-ideal.toml");
    run_ok_in(
        work.path(),
        &[
            "launch",
            launch.to_str().unwrap(),
            "scene:=multi.toml",
            "frames:=3",
            "--out",
            "run",
        ],
    );
    assert_eq!(summary(&work.path().join("run"))["frames"], 3);

    // Out of range: named, one line.
    for (flag, value) in [("--agvs", "0"), ("--agvs", "17"), ("--stations", "17")] {
        let output = run(&["scene", "--random", flag, value, "--out", "x.toml"]);
        assert!(!output.status.success());
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(stderr.contains(flag), "{stderr}");
        assert_eq!(stderr.lines().count(), 1, "{stderr}");
    }
}
