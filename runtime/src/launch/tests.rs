use super::tests_support::assert_refused;
use super::*;

const FILE: &str = r#"
[launch]
description = "test"
[arguments.angle_std_deg]
default = 1.0
[arguments.label]
default = "run"
[[node]]
name = "radar"
kind = "radar"
[node.params]
angle_std_deg = "$(var angle_std_deg)"
name = "x-$(var label)-y"
"#;

fn load(overrides: &[&str]) -> Result<Launch, LaunchError> {
    let overrides: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    Launch::parse(Path::new("launch/test.toml"), FILE, &overrides)
}

#[test]
fn defaults_and_overrides_are_substituted_with_their_types() {
    // The radar's two substituted parameters after loading with `overrides`.
    let substituted = |overrides: &[&str]| {
        let launch = load(overrides).unwrap();
        let params = &launch.nodes[0].params;
        (params["angle_std_deg"].clone(), params["name"].clone())
    };
    assert_eq!(
        substituted(&[]),
        (
            toml::Value::Float(1.0),
            toml::Value::String("x-run-y".into())
        )
    );
    assert_eq!(
        substituted(&["angle_std_deg:=5", "label:=b"]),
        (toml::Value::Float(5.0), toml::Value::String("x-b-y".into()))
    );
    assert_eq!(load(&[]).unwrap().base_dir, Path::new("launch"));
}

#[test]
fn bad_arguments_name_the_file_and_the_argument() {
    assert_refused(
        load(&["angle_std_deg:=abc"]),
        &["launch/test.toml", "angle_std_deg", "number"],
    );
    assert_refused(load(&["nope:=1"]), &["nope", "angle_std_deg, label"]);
    assert_refused(load(&["angle_std_deg=1"]), &["name:=value"]);
    assert!(load(&["angle_std_deg:=inf"]).is_err());
}

#[test]
fn path_arguments_resolve_command_line_values_against_the_current_directory() {
    let text = r#"
[arguments.scene]
default = "../config/hall.toml"
path = true
[arguments.label]
default = "out/x.toml"
[[node]]
name = "radar"
kind = "radar"
[node.params]
scene = "$(var scene)"
label = "$(var label)"
"#;
    let cwd = Path::new("/home/user/work");
    let parse = |overrides: &[&str]| {
        let overrides: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
        Launch::parse_in(Path::new("launch/l.toml"), text, &overrides, Some(cwd))
    };
    let param =
        |launch: &Launch, key: &str| launch.nodes[0].params[key].as_str().unwrap().to_owned();
    // The default is written in the file: it stays relative, for the launch file's folder.
    let launch = parse(&[]).unwrap();
    assert_eq!(param(&launch, "scene"), "../config/hall.toml");
    assert_eq!(launch.base_dir, Path::new("launch"));
    // Typed on the command line: against the current directory; the record keeps the text.
    let launch = parse(&["scene:=out/s1.toml", "label:=out/y.toml"]).unwrap();
    assert_eq!(param(&launch, "scene"), "/home/user/work/out/s1.toml");
    assert_eq!(launch.arguments["scene"].as_str(), Some("out/s1.toml"));
    // Only `path = true` arguments are paths.
    assert_eq!(param(&launch, "label"), "out/y.toml");
    let launch = parse(&["scene:=/data/s2.toml"]).unwrap();
    assert_eq!(param(&launch, "scene"), "/data/s2.toml");
    // No current directory: a relative path is an error naming the argument, not a guess.
    assert_refused(
        Launch::parse_in(
            Path::new("l.toml"),
            text,
            &["scene:=s.toml".to_owned()],
            None,
        ),
        &["argument scene", "absolute"],
    );
    // A path argument needs a string default.
    let bad = text.replace("default = \"../config/hall.toml\"", "default = 3");
    assert_refused(
        Launch::parse_in(Path::new("l.toml"), &bad, &[], Some(cwd)),
        &["argument scene", "string"],
    );
}

#[test]
fn when_conditions_select_nodes_by_argument_value() {
    let text = r#"
[arguments.fidelity]
default = "spectral"
[[node]]
name = "radar"
kind = "radar"
[[node]]
name = "estimator"
kind = "estimator"
when = { fidelity = ["spectral", "waveform"] }
"#;
    let names = |overrides: &[&str]| {
        let overrides: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
        Launch::parse(Path::new("l.toml"), text, &overrides)
            .unwrap()
            .nodes
            .into_iter()
            .map(|n| n.name)
            .collect::<Vec<_>>()
    };
    assert_eq!(names(&[]), ["radar", "estimator"]);
    assert_eq!(names(&["fidelity:=waveform"]), ["radar", "estimator"]);
    assert_eq!(names(&["fidelity:=ideal"]), ["radar"]);
    let bad = text.replace("when = { fidelity", "when = { fidel");
    assert_refused(
        Launch::parse(Path::new("l.toml"), &bad, &[]),
        &["node estimator", "fidel"],
    );
}

fn substitution(arguments: &[(&str, &str)], param: &str) -> Result<Launch, LaunchError> {
    let mut text = String::new();
    for (name, default) in arguments {
        text.push_str(&format!("[arguments.{name}]\ndefault = {default:?}\n"));
    }
    text.push_str(&format!(
        "[[node]]\nname = \"n\"\nkind = \"k\"\n[node.params]\nx = {param:?}\n"
    ));
    Launch::parse(Path::new("s.toml"), &text, &[])
}

#[test]
fn arguments_may_name_other_arguments() {
    let launch = substitution(
        &[
            ("label", "b"),
            ("out", "runs/$(var label)/x"),
            ("n", "$(var out)"),
        ],
        "$(var n)-$(var label)",
    )
    .unwrap();
    assert_eq!(launch.nodes[0].params["x"].as_str(), Some("runs/b/x-b"));
    // The record keeps the values as typed.
    assert_eq!(
        launch.arguments["out"].as_str(),
        Some("runs/$(var label)/x")
    );
    // A whole-value reference to a string argument that names another.
    let launch = substitution(&[("a", "$(var b)"), ("b", "z")], "$(var a)").unwrap();
    assert_eq!(launch.nodes[0].params["x"].as_str(), Some("z"));
}

#[test]
fn substitution_cycles_are_reported_with_their_arguments() {
    let error = substitution(&[("a", "$(var b)"), ("b", "x$(var a)")], "$(var a)")
        .unwrap_err()
        .to_string();
    assert!(
        error.starts_with("s.toml: argument a: ")
            && error.contains("substitution cycle: a -> b -> a"),
        "{error}"
    );
    assert_refused(
        substitution(&[("a", "$(var a)")], "y"),
        &["substitution cycle: a -> a"],
    );
    // A cycle entered through the command line is caught too.
    let text = "[arguments.a]\ndefault = \"1\"\n[arguments.b]\ndefault = \"$(var a)\"\n\
                [[node]]\nname = \"n\"\nkind = \"k\"\n[node.params]\nx = \"$(var b)\"\n";
    assert_refused(
        Launch::parse(Path::new("s.toml"), text, &["a:=-$(var b)-".to_owned()]),
        &["substitution cycle: a -> b -> a"],
    );
}

/// `n` arguments `{prefix}00`, `{prefix}01`, ..., each defaulting to `link` with `{next}` the
/// next one's name, the last to `end`.
fn chain(prefix: &str, n: usize, link: &str, end: &str) -> Vec<(String, String)> {
    let names: Vec<String> = (0..n).map(|i| format!("{prefix}{i:02}")).collect();
    (0..n)
        .map(|i| {
            let default = match names.get(i + 1) {
                Some(next) => link.replace("{next}", next),
                None => end.to_owned(),
            };
            (names[i].clone(), default)
        })
        .collect()
}

/// `chain` as the (name, default) pairs [`substitution`] takes.
fn as_pairs(chain: &[(String, String)]) -> Vec<(&str, &str)> {
    chain
        .iter()
        .map(|(n, d)| (n.as_str(), d.as_str()))
        .collect()
}

#[test]
fn substitution_depth_and_length_are_bounded() {
    // A chain longer than the depth bound.
    let deep = chain("a", MAX_SUBSTITUTION_DEPTH + 2, "$(var {next})", "end");
    let arguments = as_pairs(&deep);
    assert_refused(
        substitution(&arguments, "$(var a00)"),
        &[&format!("deeper than {MAX_SUBSTITUTION_DEPTH}")],
    );
    // A chain within the bound expands.
    let short = &arguments[arguments.len() - MAX_SUBSTITUTION_DEPTH..];
    let launch = substitution(short, &format!("$(var {})", short[0].0)).unwrap();
    assert_eq!(launch.nodes[0].params["x"].as_str(), Some("end"));
    // Doubling at each of 30 levels would make 2^30 copies: refused, quickly.
    let doubling = chain("d", 30, "$(var {next})$(var {next})", "xxxxxxxx");
    let arguments = as_pairs(&doubling);
    let started = std::time::Instant::now();
    assert_refused(
        substitution(&arguments, "$(var d00)"),
        &[&format!("longer than {MAX_SUBSTITUTED_BYTES} bytes")],
    );
    assert!(started.elapsed().as_secs_f64() < 5.0);
    // An unterminated reference in an argument's value names the argument.
    assert_refused(
        substitution(&[("a", "$(var b")], "y"),
        &["argument a", "unterminated"],
    );
}

#[test]
fn respawn_is_declared_per_node_and_its_bounds_are_checked() {
    let text = "[[node]]\nname=\"a\"\nkind=\"mapper\"\nrespawn = true\nrespawn_delay_s = 0.5\n";
    let launch = Launch::parse(Path::new("f.toml"), text, &[]).unwrap();
    let node = &launch.nodes[0];
    assert!(node.respawn);
    assert_eq!((node.respawn_delay_s, node.max_restarts), (0.5, 3));
    let plain = Launch::parse(
        Path::new("f.toml"),
        "[[node]]\nname=\"a\"\nkind=\"b\"\n",
        &[],
    )
    .unwrap();
    assert!(!plain.nodes[0].respawn);
    for bad in [
        "respawn_delay_s = -1.0",
        "respawn_delay_s = 1e19",
        "max_restarts = 5000",
    ] {
        let error = Launch::parse(
            Path::new("f.toml"),
            &format!("[[node]]\nname=\"a\"\nkind=\"b\"\n{bad}\n"),
            &[],
        )
        .unwrap_err()
        .to_string();
        assert!(
            error.contains("node a") && error.contains("allowed: 0 to 3600 s"),
            "{bad}: {error}"
        );
    }
}

#[test]
fn unknown_fields_and_duplicates_are_refused_with_a_line() {
    let error = Launch::parse(
        Path::new("f.toml"),
        "[launch]\nmode = \"in-process\"\nspeed = 3\n[[node]]\nname=\"a\"\nkind=\"b\"\n",
        &[],
    )
    .unwrap_err()
    .to_string();
    assert!(
        error.starts_with("f.toml:") && error.contains("speed") && error.contains("line 3"),
        "{error}"
    );
    assert_refused(
        Launch::parse(
            Path::new("f.toml"),
            "[[node]]\nname=\"a\"\nkind=\"b\"\n[[node]]\nname=\"a\"\nkind=\"c\"\n",
            &[],
        ),
        &["node a", "twice"],
    );
    assert_refused(
        Launch::parse(
            Path::new("f.toml"),
            "[[node]]\nname=\"a\"\nkind=\"b\"\n[node.params]\nx=\"$(var y)\"\n",
            &[],
        ),
        &["undeclared argument \"y\""],
    );
}

const EXTERNAL_FILE: &str = r#"
[arguments.source]
default = "bag"
[[external]]
topic = "/odom"
when = { source = ["external"] }
[[external]]
topic = "/radar/points"
[[external]]
topic = "/radar/points"
[[node]]
name = "mapper"
kind = "mapper"
"#;

#[test]
fn externals_follow_their_when_and_are_listed_once() {
    let parse = |overrides: &[String]| {
        Launch::parse(Path::new("launch/test.toml"), EXTERNAL_FILE, overrides).unwrap()
    };
    assert_eq!(parse(&[]).externals, vec!["/radar/points"]);
    assert_eq!(
        parse(&["source:=external".into()]).externals,
        vec!["/odom", "/radar/points"]
    );
}

#[test]
fn a_bad_external_is_refused_naming_it() {
    let refused = |text: &str| {
        Launch::parse(Path::new("launch/test.toml"), text, &[])
            .unwrap_err()
            .to_string()
    };
    let node = "[[node]]\nname = \"mapper\"\nkind = \"mapper\"\n";
    let error = refused(&format!("[[external]]\ntopic = \"odom\"\n{node}"));
    assert!(
        error.contains("external odom: `topic` must be a topic name starting with '/'"),
        "{error}"
    );
    let error = refused(&format!(
        "[[external]]\ntopic = \"/odom\"\nwhen = {{ nope = [\"x\"] }}\n{node}"
    ));
    assert!(
        error.contains("external /odom: `when` names undeclared argument \"nope\""),
        "{error}"
    );
    let error = refused(&format!("[[external]]\ntopic = \"/odom\"\nqos = 1\n{node}"));
    assert!(error.contains("unknown field `qos`"), "{error}");
}
