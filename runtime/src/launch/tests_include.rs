//! Tests of `[[include]]` and of command-line node-parameter overrides.

use super::tests_support::assert_refused;
use super::*;
use std::path::Path;

const BASE: &str = r#"
[arguments.gain]
default = 1.0
[arguments.count]
default = 5
[arguments.scene]
default = "scenes/s.toml"
path = true
[[node]]
name = "radar"
kind = "radar"
[node.params]
gain = "$(var gain)"
count = "$(var count)"
scene = "$(var scene)"
[node.params.inner]
a = 1
b = 2
[[node]]
name = "mapper"
kind = "mapper"
"#;

/// Writes `files` (name, text) into a new folder.
fn folder(files: &[(&str, &str)]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for (name, text) in files {
        let path = dir.path().join(name);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, text).unwrap();
    }
    dir
}

fn load(dir: &Path, file: &str, overrides: &[&str]) -> Result<Launch, LaunchError> {
    let overrides: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    let path = dir.join(file);
    let text = std::fs::read_to_string(&path).unwrap();
    Launch::parse_in(&path, &text, &overrides, Some(Path::new("/cwd")))
}

fn names(launch: &Launch) -> Vec<&str> {
    launch.nodes.iter().map(|n| n.name.as_str()).collect()
}

#[test]
fn an_include_adds_its_nodes_with_the_includers_arguments_by_name() {
    let top = r#"
[arguments.gain]
default = 2.5
[[include]]
file = "base.toml"
[include.params.radar]
extra = true
[include.params.radar.inner]
b = 20
[[node]]
name = "evaluator"
kind = "evaluator"
"#;
    let dir = folder(&[("base.toml", BASE), ("top.toml", top)]);
    let launch = load(dir.path(), "top.toml", &[]).unwrap();
    assert_eq!(names(&launch), ["radar", "mapper", "evaluator"]);
    let radar = &launch.nodes[0];
    // The includer's `gain` reaches the included file's `gain`; `count` keeps its default.
    assert_eq!(radar.params["gain"], toml::Value::Float(2.5));
    assert_eq!(radar.params["count"], toml::Value::Integer(5));
    assert_eq!(radar.params["extra"], toml::Value::Boolean(true));
    // Tables merge key by key.
    let inner = radar.params["inner"].as_table().unwrap();
    assert_eq!(
        (inner["a"].as_integer(), inner["b"].as_integer()),
        (Some(1), Some(20))
    );
    assert_eq!(radar.file, dir.path().join("base.toml"));
    assert_eq!(radar.base_dir, dir.path());
    assert!(radar.describe(&launch.path).contains("base.toml"));
    assert!(radar.set_by[0].ends_with("top.toml [include.params.radar]"));
    // Arguments of the included file that the includer does not set become the includer's.
    let settable: Vec<&String> = launch.declared.keys().collect();
    assert_eq!(settable, ["count", "gain", "scene"]);
    assert_eq!(launch.arguments["count"], toml::Value::Integer(5));
    let launch = load(dir.path(), "top.toml", &["count:=7", "gain:=3"]).unwrap();
    assert_eq!(launch.nodes[0].params["count"], toml::Value::Integer(7));
    assert_eq!(launch.nodes[0].params["gain"], toml::Value::Float(3.0));
    assert_eq!(launch.arguments["count"], toml::Value::Integer(7));
    assert_refused(
        load(dir.path(), "top.toml", &["nope:=1"]),
        &["argument nope: not declared (declared: count, gain, scene)"],
    );
    assert_refused(
        load(dir.path(), "top.toml", &["count:=x"]),
        &["base.toml: argument count", "not an integer"],
    );
}

#[test]
fn include_arguments_are_substituted_and_not_settable_from_above() {
    let top = r#"
[arguments.n]
default = 3
[[include]]
file = "base.toml"
arguments = { count = "$(var n)", gain = "4" }
"#;
    let dir = folder(&[("base.toml", BASE), ("top.toml", top)]);
    let launch = load(dir.path(), "top.toml", &["n:=9"]).unwrap();
    assert_eq!(launch.nodes[0].params["count"], toml::Value::Integer(9));
    // A string that parses as the argument's type is taken as that type.
    assert_eq!(launch.nodes[0].params["gain"], toml::Value::Float(4.0));
    assert_refused(
        load(dir.path(), "top.toml", &["count:=1"]),
        &["argument count: not declared"],
    );
    let bad = top.replace("gain = \"4\"", "gane = 4.0");
    let dir = folder(&[("base.toml", BASE), ("top.toml", &bad)]);
    assert_refused(
        load(dir.path(), "top.toml", &[]),
        &[
            "include base.toml: arguments.gane",
            "its arguments: count, gain, scene",
        ],
    );
    let bad = top.replace("gain = \"4\"", "gain = true");
    let dir = folder(&[("base.toml", BASE), ("top.toml", &bad)]);
    assert_refused(
        load(dir.path(), "top.toml", &[]),
        &["argument gain: the including file passes true, which is not a number"],
    );
}

#[test]
fn when_selects_an_include_and_drop_replaces_a_node() {
    let other = BASE.replace("name = \"radar\"", "name = \"radar\"\n# other");
    let top = r#"
[arguments.fidelity]
default = "ideal"
[[include]]
file = "base.toml"
when = { fidelity = ["ideal"] }
[[include]]
file = "other.toml"
when = { fidelity = ["spectral"] }
drop = ["mapper"]
[[node]]
name = "mapper"
kind = "mapper2"
when = { fidelity = ["spectral"] }
"#;
    let dir = folder(&[
        ("base.toml", BASE),
        ("other.toml", &other),
        ("top.toml", top),
    ]);
    let launch = load(dir.path(), "top.toml", &[]).unwrap();
    assert_eq!(names(&launch), ["radar", "mapper"]);
    assert_eq!(launch.nodes[1].kind, "mapper");
    assert!(launch.nodes[0].file.ends_with("base.toml"));
    let launch = load(dir.path(), "top.toml", &["fidelity:=spectral"]).unwrap();
    assert_eq!(names(&launch), ["radar", "mapper"]);
    assert_eq!(launch.nodes[1].kind, "mapper2");
    assert!(launch.nodes[0].file.ends_with("other.toml"));
    // Without the drop, two nodes would have one name.
    let clash = top.replace("drop = [\"mapper\"]", "");
    let dir = folder(&[
        ("base.toml", BASE),
        ("other.toml", &other),
        ("top.toml", &clash),
    ]);
    assert_refused(
        load(dir.path(), "top.toml", &["fidelity:=spectral"]),
        &[
            "include other.toml: node mapper is declared in this file",
            "drop",
        ],
    );
    // An include's `when` names the includer's arguments; a missing file is reported even when
    // the include is off.
    let bad = top.replace(
        "when = { fidelity = [\"ideal\"] }",
        "when = { fidel = [\"ideal\"] }",
    );
    let dir = folder(&[
        ("base.toml", BASE),
        ("other.toml", &other),
        ("top.toml", &bad),
    ]);
    assert_refused(
        load(dir.path(), "top.toml", &[]),
        &["undeclared argument \"fidel\""],
    );
    let dir = folder(&[("base.toml", BASE), ("top.toml", top)]);
    assert_refused(
        load(dir.path(), "top.toml", &[]),
        &["include other.toml: no such file"],
    );
}

#[test]
fn unknown_fields_nodes_and_conflicts_are_refused() {
    let with = |extra: &str| format!("[[include]]\nfile = \"base.toml\"\n{extra}\n");
    let error_of = |top: &str| {
        let dir = folder(&[("base.toml", BASE), ("top.toml", top)]);
        load(dir.path(), "top.toml", &[]).unwrap_err().to_string()
    };
    let error = error_of(&with("argumentz = {}"));
    assert!(
        error.contains("argumentz") && error.contains("line"),
        "{error}"
    );
    let error = error_of(&with("drop = [\"segmenter\"]"));
    assert!(
        error.contains("drop: ") && error.contains("no node segmenter (its nodes: radar, mapper)"),
        "{error}"
    );
    let error = error_of(&with("[include.params.segmenter]\nx = 1"));
    assert!(error.contains("params.segmenter: "), "{error}");
    let error = error_of(&with("[include.params.radar]\nx = \"$(var y)\""));
    assert!(
        error.contains("params.radar: uses undeclared argument \"y\""),
        "{error}"
    );
    // An error inside the included file names both files.
    let dir = folder(&[
        ("base.toml", "[[node]]\nname = 1\n"),
        ("top.toml", &with("")),
    ]);
    assert_refused(
        load(dir.path(), "top.toml", &[]),
        &[
            "top.toml: include base.toml: ",
            "base.toml: invalid type",
            "line 2",
        ],
    );
    // Two includes re-exporting one argument with different defaults: the includer decides.
    let other = BASE
        .replace("default = 5", "default = 6")
        .replace("\"radar\"", "\"r2\"")
        .replace("\"mapper\"", "\"m2\"");
    let two = format!("{}[[include]]\nfile = \"other.toml\"\n", with(""));
    let dir = folder(&[
        ("base.toml", BASE),
        ("other.toml", &other),
        ("top.toml", &two),
    ]);
    assert_refused(
        load(dir.path(), "top.toml", &[]),
        &["argument count is declared by", "(default 6)"],
    );
    // Given on the command line, both take it and agree.
    let launch = load(dir.path(), "top.toml", &["count:=8"]).unwrap();
    assert_eq!(launch.nodes[2].params["count"], toml::Value::Integer(8));
}

#[test]
fn include_cycles_and_depth_are_refused_naming_the_chain() {
    let dir = folder(&[
        ("a.toml", "[[include]]\nfile = \"sub/b.toml\"\n"),
        ("sub/b.toml", "[[include]]\nfile = \"../a.toml\"\n"),
    ]);
    let error = load(dir.path(), "a.toml", &[]).unwrap_err().to_string();
    let a = dir.path().join("a.toml").display().to_string();
    let b = dir.path().join("sub/b.toml").display().to_string();
    let again = dir.path().join("sub/../a.toml").display().to_string();
    assert!(
        error.contains(&format!("include cycle: {a} -> {b} -> {again}")),
        "{error}"
    );
    // A file including itself.
    let dir = folder(&[("a.toml", "[[include]]\nfile = \"a.toml\"\n")]);
    assert_refused(load(dir.path(), "a.toml", &[]), &["include cycle"]);
    // f0 includes f1 ... includes f{depth}, which declares a node.
    let chain = |depth: usize| {
        let mut files: Vec<(String, String)> = (0..depth)
            .map(|i| {
                (
                    format!("f{i}.toml"),
                    format!("[[include]]\nfile = \"f{}.toml\"\n", i + 1),
                )
            })
            .collect();
        files.push((
            format!("f{depth}.toml"),
            "[[node]]\nname = \"n\"\nkind = \"k\"\n".into(),
        ));
        let files: Vec<(&str, &str)> = files
            .iter()
            .map(|(n, t)| (n.as_str(), t.as_str()))
            .collect();
        let dir = folder(&files);
        load(dir.path(), "f0.toml", &[])
    };
    assert_eq!(names(&chain(MAX_INCLUDE_DEPTH).unwrap()), ["n"]);
    assert_refused(
        chain(MAX_INCLUDE_DEPTH + 1),
        &[
            &format!("includes nested deeper than {MAX_INCLUDE_DEPTH}: "),
            "f0.toml -> ",
            "f9.toml",
        ],
    );
}

#[test]
fn paths_in_an_included_file_resolve_against_its_folder() {
    let top_default = r#"
[[include]]
file = "sub/base.toml"
"#;
    let dir = folder(&[("sub/base.toml", BASE), ("top.toml", top_default)]);
    let launch = load(dir.path(), "top.toml", &[]).unwrap();
    let radar = &launch.nodes[0];
    // Its own default stays relative, for its own folder.
    assert_eq!(radar.params["scene"].as_str(), Some("scenes/s.toml"));
    assert_eq!(radar.base_dir, dir.path().join("sub"));
    assert_eq!(launch.base_dir, dir.path());
    // Typed on the command line: against the current directory; recorded as typed.
    let launch = load(dir.path(), "top.toml", &["scene:=mine.toml"]).unwrap();
    assert_eq!(
        launch.nodes[0].params["scene"].as_str(),
        Some("/cwd/mine.toml")
    );
    assert_eq!(launch.arguments["scene"].as_str(), Some("mine.toml"));
    // Written in the includer's folder (its default, or `$(var ...)` of it): against that folder.
    let top_own = r#"
[arguments.scene]
default = "here.toml"
path = true
[arguments.other]
default = "there.toml"
path = true
[[include]]
file = "sub/base.toml"
"#;
    let dir = folder(&[("sub/base.toml", BASE), ("top.toml", top_own)]);
    let launch = load(dir.path(), "top.toml", &[]).unwrap();
    let expected = dir.path().join("here.toml").display().to_string();
    assert_eq!(
        launch.nodes[0].params["scene"].as_str(),
        Some(expected.as_str())
    );
    let explicit = format!("{top_own}arguments = {{ scene = \"$(var other)\" }}\n");
    let dir = folder(&[("sub/base.toml", BASE), ("top.toml", &explicit)]);
    let launch = load(dir.path(), "top.toml", &[]).unwrap();
    let expected = dir.path().join("there.toml").display().to_string();
    assert_eq!(
        launch.nodes[0].params["scene"].as_str(),
        Some(expected.as_str())
    );
    // Same folder: nothing to rebase, the value stays as written.
    let dir = folder(&[
        ("base.toml", BASE),
        ("top.toml", &top_own.replace("sub/", "")),
    ]);
    let launch = load(dir.path(), "top.toml", &[]).unwrap();
    assert_eq!(launch.nodes[0].params["scene"].as_str(), Some("here.toml"));
}

#[test]
fn node_parameter_overrides_set_nested_values_and_are_recorded() {
    let dir = folder(&[("base.toml", BASE)]);
    let launch = load(
        dir.path(),
        "base.toml",
        &[
            "radar.gain:=0.25",
            "radar.inner.c:=true",
            "radar.new.deep.k:=\"v\"",
            "count:=2",
        ],
    )
    .unwrap();
    let radar = &launch.nodes[0];
    assert_eq!(radar.params["gain"], toml::Value::Float(0.25));
    assert_eq!(radar.params["count"], toml::Value::Integer(2));
    let inner = radar.params["inner"].as_table().unwrap();
    assert_eq!(
        (inner["a"].as_integer(), inner["c"].as_bool()),
        (Some(1), Some(true))
    );
    assert_eq!(radar.params["new"]["deep"]["k"].as_str(), Some("v"));
    assert_eq!(launch.arguments["radar.gain"], toml::Value::Float(0.25));
    assert_eq!(
        launch.arguments["radar.inner.c"],
        toml::Value::Boolean(true)
    );
    assert!(
        radar
            .describe(&launch.path)
            .contains("the command line (radar.gain:=0.25)"),
        "{}",
        radar.describe(&launch.path)
    );
    assert_refused(
        load(dir.path(), "base.toml", &["segmenter.eps_m:=1"]),
        &["segmenter.eps_m:=1: no node segmenter in this launch (nodes: radar, mapper)"],
    );
    assert_refused(
        load(dir.path(), "base.toml", &["radar.gain.x:=1"]),
        &["radar.gain is float, not a table"],
    );
    assert_refused(
        load(dir.path(), "base.toml", &["radar.:=1"]),
        &["node.param:=value"],
    );
    // A node its `when` leaves out.
    let gated = "[arguments.on]\ndefault = false\n[[node]]\nname = \"a\"\nkind = \"k\"\n\
                 [[node]]\nname = \"b\"\nkind = \"k\"\nwhen = { on = [\"true\"] }\n";
    let dir = folder(&[("g.toml", gated)]);
    let error = load(dir.path(), "g.toml", &["b.x:=1"])
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("node b does not run with these arguments"),
        "{error}"
    );
    assert!(load(dir.path(), "g.toml", &["b.x:=1", "on:=true"]).is_ok());
    // Nothing left to run is an error, not an empty graph.
    let none = gated.replace(
        "name = \"a\"\nkind = \"k\"\n",
        "name = \"a\"\nkind = \"k\"\nwhen = { on = [\"true\"] }\n",
    );
    let dir = folder(&[("g.toml", &none)]);
    assert_refused(
        load(dir.path(), "g.toml", &[]),
        &["no node runs with these arguments"],
    );
}

#[test]
fn on_exit_is_a_nodes_and_an_include_sets_it_for_every_node_it_adds() {
    let top = r#"
[[include]]
file = "base.toml"
namespace = "agv1"
on_exit = "continue"
[[include]]
file = "base.toml"
namespace = "agv2"
[[node]]
name = "fusion"
kind = "fusion"
on_exit = "stop"
"#;
    let dir = folder(&[("top.toml", top), ("base.toml", BASE)]);
    let launch = load(dir.path(), "top.toml", &[]).unwrap();
    let on_exit: Vec<(&str, crate::supervisor::OnExit)> = launch
        .nodes
        .iter()
        .map(|n| (n.name.as_str(), n.on_exit))
        .collect();
    use crate::supervisor::OnExit::{Continue, Stop};
    assert_eq!(
        on_exit,
        [
            ("agv1/radar", Continue),
            ("agv1/mapper", Continue),
            ("agv2/radar", Stop),
            ("agv2/mapper", Stop),
            ("fusion", Stop),
        ]
    );
    // Any other value: refused with the file's line and the two allowed.
    for (bad, line) in [
        (
            "[[node]]\nname = \"a\"\nkind = \"b\"\non_exit = \"ignore\"\n",
            4,
        ),
        (
            "[[include]]\nfile = \"base.toml\"\non_exit = \"restart\"\n",
            3,
        ),
    ] {
        let dir = folder(&[("top.toml", bad), ("base.toml", BASE)]);
        assert_refused(
            load(dir.path(), "top.toml", &[]),
            &["expected `stop` or `continue`", &format!("(line {line})")],
        );
    }
}

#[test]
fn an_include_respawns_the_nodes_it_names_and_refuses_a_name_it_does_not_add() {
    let top = r#"
[[include]]
file = "base.toml"
namespace = "agv1"
respawn = ["mapper"]
[[include]]
file = "base.toml"
namespace = "agv2"
"#;
    let dir = folder(&[("top.toml", top), ("base.toml", BASE)]);
    let launch = load(dir.path(), "top.toml", &[]).unwrap();
    let respawn: Vec<(&str, bool)> = launch
        .nodes
        .iter()
        .map(|n| (n.name.as_str(), n.respawn))
        .collect();
    assert_eq!(
        respawn,
        [
            ("agv1/radar", false),
            ("agv1/mapper", true),
            ("agv2/radar", false),
            ("agv2/mapper", false),
        ]
    );
    let unknown = top.replace("respawn = [\"mapper\"]", "respawn = [\"association\"]");
    let dir = folder(&[("top.toml", &unknown), ("base.toml", BASE)]);
    assert_refused(
        load(dir.path(), "top.toml", &[]),
        &["respawn:", "declares no node association"],
    );
    let dropped = top.replace(
        "respawn = [\"mapper\"]",
        "respawn = [\"mapper\"]\ndrop = [\"mapper\"]",
    );
    let dir = folder(&[("top.toml", &dropped), ("base.toml", BASE)]);
    assert_refused(
        load(dir.path(), "top.toml", &[]),
        &["respawn: mapper is in this include's `drop`"],
    );
}
