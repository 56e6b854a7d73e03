//! Tests of namespaces and remaps: `[[node]] namespace`/`remap`, `[[include]] namespace`/`repeat`
//! with `$(index)`, and the names of namespaced nodes where names are used.

use super::tests_support::assert_refused;
use super::*;
use std::path::Path;

/// One agent: a radar and an association, the agent's name an argument.
const AGENT: &str = r#"
[arguments.agent]
default = "solo"
[arguments.snr_db]
default = 10.0
[[node]]
name = "radar"
kind = "radar"
[node.params]
label = "$(var agent)"
snr_db = "$(var snr_db)"
[[node]]
name = "association"
kind = "association"
"#;

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

fn parse(text: &str, overrides: &[&str]) -> Result<Launch, LaunchError> {
    let overrides: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    Launch::parse_in(
        Path::new("l.toml"),
        text,
        &overrides,
        Some(Path::new("/cwd")),
    )
}

fn names(launch: &Launch) -> Vec<&str> {
    launch.nodes.iter().map(|n| n.name.as_str()).collect()
}

#[test]
fn a_node_namespace_names_the_node_and_remap_values_take_arguments() {
    let text = r#"
[arguments.agent]
default = "agv1"
[[node]]
name = "radar"
kind = "radar"
namespace = "$(var agent)"
remap = { "/ground_truth/targets" = "/ground_truth/targets", "/odom" = "/$(var agent)/odom" }
[[node]]
name = "radar"
kind = "radar"
namespace = "agv2"
[[node]]
name = "mapper"
kind = "mapper"
"#;
    let launch = parse(text, &[]).unwrap();
    assert_eq!(names(&launch), ["agv1/radar", "agv2/radar", "mapper"]);
    let radar = &launch.nodes[0];
    assert_eq!(radar.namespace, "agv1");
    assert_eq!(radar.local_name(), "radar");
    assert_eq!(radar.remap["/odom"], "/agv1/odom");
    assert_eq!(
        radar.remap["/ground_truth/targets"],
        "/ground_truth/targets"
    );
    assert_eq!(launch.nodes[2].local_name(), "mapper");
    assert_eq!(launch.nodes[2].namespace, "");
    // Another namespace for the same node name: no clash; the same one: a clash.
    let twice = text.replace("namespace = \"agv2\"", "namespace = \"agv1\"");
    // Told apart after substitution: both are agv1/radar.
    assert_refused(
        parse(&twice, &[]),
        &["node agv1/radar: name used twice (after substituting the namespaces)"],
    );
    // Written alike: refused as written.
    let substituted = text.replace("namespace = \"agv2\"", "namespace = \"$(var agent)\"");
    assert_refused(parse(&substituted, &[]), &["node radar: name used twice"]);
}

#[test]
fn bad_namespaces_names_and_remaps_are_refused_naming_the_field() {
    let node = |extra: &str| format!("[[node]]\nname = \"radar\"\nkind = \"radar\"\n{extra}\n");
    for (extra, needles) in [
        (
            "namespace = \"agv 1\"",
            &["node radar", "namespace \"agv 1\"", "segment"][..],
        ),
        (
            "namespace = \"/agv1\"",
            &["node radar", "starts or ends with '/'"][..],
        ),
        ("namespace = \"1agv\"", &["segment \"1agv\""][..]),
        (
            "remap = { \"/odom\" = \"odom\" }",
            &["node radar", "remap.\"/odom\" = \"odom\"", "absolute"][..],
        ),
        (
            "remap = { \"/odom\" = \"/agv1/nothing\" }",
            &["remap.\"/odom\"", "not a catalogue topic"][..],
        ),
        (
            "remap = { \"odom\" = \"/odom\" }",
            &["remap.\"odom\"", "one of the node's own topics"][..],
        ),
        ("remap = { \"/odom\" = 3 }", &["line"][..]),
    ] {
        assert_refused(parse(&node(extra), &[]), needles);
    }
    assert_refused(
        parse("[[node]]\nname = \"agv1/radar\"\nkind = \"radar\"\n", &[]),
        &["node agv1/radar", "no '/'", "namespace"],
    );
}

#[test]
fn a_repeated_include_makes_one_copy_per_index_under_its_namespace() {
    let top = r#"
[arguments.agents]
default = 3
[[include]]
file = "agent.toml"
repeat = "$(var agents)"
namespace = "agv$(index)"
arguments = { agent = "agv$(index)", snr_db = "$(index)" }
[include.params.radar]
seed_label = "copy-$(index)"
frame = "$(index)"
[[node]]
name = "fusion"
kind = "mapper"
"#;
    let dir = folder(&[("agent.toml", AGENT), ("top.toml", top)]);
    let launch = load(dir.path(), "top.toml", &[]).unwrap();
    assert_eq!(
        names(&launch),
        [
            "agv1/radar",
            "agv1/association",
            "agv2/radar",
            "agv2/association",
            "agv3/radar",
            "agv3/association",
            "fusion"
        ]
    );
    let radar2 = &launch.nodes[2];
    assert_eq!(radar2.namespace, "agv2");
    assert_eq!(radar2.params["label"].as_str(), Some("agv2"));
    // A whole "$(index)" is the integer (taken as a float by a float argument).
    assert_eq!(radar2.params["snr_db"], toml::Value::Float(2.0));
    assert_eq!(radar2.params["frame"], toml::Value::Integer(2));
    assert_eq!(radar2.params["seed_label"].as_str(), Some("copy-2"));
    // `repeat` from the command line; 0 includes nothing.
    let launch = load(dir.path(), "top.toml", &["agents:=1"]).unwrap();
    assert_eq!(names(&launch), ["agv1/radar", "agv1/association", "fusion"]);
    let launch = load(dir.path(), "top.toml", &["agents:=0"]).unwrap();
    assert_eq!(names(&launch), ["fusion"]);
    // A namespaced node's parameter from the command line, by its full name.
    let launch = load(dir.path(), "top.toml", &["agv2/radar.snr_db:=3"]).unwrap();
    assert_eq!(launch.nodes[2].params["snr_db"], toml::Value::Integer(3));
    assert_eq!(launch.nodes[0].params["snr_db"], toml::Value::Float(1.0));
    assert_eq!(
        launch.arguments["agv2/radar.snr_db"],
        toml::Value::Integer(3)
    );
    assert_refused(
        load(dir.path(), "top.toml", &["radar.snr_db:=3"]),
        &["radar.snr_db:=3", "no node radar", "agv1/radar"],
    );
    assert_refused(
        load(
            dir.path(),
            "top.toml",
            &["agents:=2", "agv3/radar.snr_db:=3"],
        ),
        &["no node agv3/radar"],
    );
}

#[test]
fn skip_first_leaves_out_the_first_copies_and_keeps_the_others_numbers() {
    let top = r#"
[arguments.agvs]
default = 3
[arguments.known]
default = 1
[[include]]
file = "agent.toml"
repeat = "$(var known)"
namespace = "agv$(index)"
[include.params.radar]
origin = "map"
[[include]]
file = "agent.toml"
repeat = "$(var agvs)"
skip_first = "$(var known)"
namespace = "agv$(index)"
drop = ["association"]
[include.params.radar]
origin = "start-$(index)"
"#;
    let dir = folder(&[("agent.toml", AGENT), ("top.toml", top)]);
    let launch = load(dir.path(), "top.toml", &[]).unwrap();
    assert_eq!(
        names(&launch),
        ["agv1/radar", "agv1/association", "agv2/radar", "agv3/radar"]
    );
    let origins: Vec<&str> = launch
        .nodes
        .iter()
        .filter_map(|n| n.params.get("origin").and_then(toml::Value::as_str))
        .collect();
    assert_eq!(origins, ["map", "start-2", "start-3"]);
    // Skipping every copy, or more, leaves none.
    let launch = load(dir.path(), "top.toml", &["known:=3"]).unwrap();
    assert_eq!(names(&launch).len(), 6);
    let launch = load(dir.path(), "top.toml", &["agvs:=1", "known:=2"]).unwrap();
    assert_eq!(
        names(&launch),
        [
            "agv1/radar",
            "agv1/association",
            "agv2/radar",
            "agv2/association"
        ]
    );
    assert_refused(
        load(dir.path(), "top.toml", &["known:=-1"]),
        &["repeat: \"$(var known)\" (= -1) is out of range"],
    );
    let no_repeat = "[[include]]\nfile = \"agent.toml\"\nskip_first = 1\n";
    let dir = folder(&[("agent.toml", AGENT), ("top.toml", no_repeat)]);
    assert_refused(
        load(dir.path(), "top.toml", &[]),
        &["include agent.toml: skip_first", "`repeat`"],
    );
}

#[test]
fn bad_repeats_are_refused_naming_the_field() {
    let top = |repeat: &str| {
        format!(
            "[arguments.n]\ndefault = 2\n[arguments.word]\ndefault = \"x\"\n[[include]]\nfile = \
             \"agent.toml\"\nrepeat = {repeat}\nnamespace = \"agv$(index)\"\n"
        )
    };
    for (repeat, needles) in [
        (
            "-1",
            &[
                "include agent.toml",
                "repeat: -1 is out of range",
                "0 to 64",
            ][..],
        ),
        ("65", &["repeat: 65 is out of range"][..]),
        ("2.5", &["repeat: 2.5 is not an integer"][..]),
        ("true", &["repeat: true is not an integer"][..]),
        (
            "\"$(var word)\"",
            &["repeat: \"$(var word)\" (= \"x\") is not an integer"][..],
        ),
        ("\"many\"", &["repeat: \"many\" is not an integer"][..]),
        (
            "\"$(var nope)\"",
            &["repeat: uses undeclared argument \"nope\""][..],
        ),
    ] {
        let dir = folder(&[("agent.toml", AGENT), ("top.toml", &top(repeat))]);
        assert_refused(load(dir.path(), "top.toml", &[]), needles);
    }
    // From the command line: the argument's value is checked as the include uses it.
    let dir = folder(&[("agent.toml", AGENT), ("top.toml", &top("\"$(var n)\""))]);
    assert_refused(
        load(dir.path(), "top.toml", &["n:=-3"]),
        &["repeat: \"$(var n)\" (= -3) is out of range"],
    );
    assert_refused(
        load(dir.path(), "top.toml", &["n:=100"]),
        &["(= 100) is out of range"],
    );
    assert_eq!(
        load(dir.path(), "top.toml", &["n:=2"]).unwrap().nodes.len(),
        4
    );
}

#[test]
fn index_without_repeat_and_copies_without_index_are_refused() {
    let no_repeat = "[[include]]\nfile = \"agent.toml\"\nnamespace = \"agv$(index)\"\n";
    let dir = folder(&[("agent.toml", AGENT), ("top.toml", no_repeat)]);
    assert_refused(
        load(dir.path(), "top.toml", &[]),
        &["include agent.toml", "namespace: $(index)", "repeat"],
    );
    let in_arguments =
        "[[include]]\nfile = \"agent.toml\"\narguments = { agent = \"a$(index)\" }\n";
    let dir = folder(&[("agent.toml", AGENT), ("top.toml", in_arguments)]);
    assert_refused(
        load(dir.path(), "top.toml", &[]),
        &["arguments.agent: $(index)"],
    );
    let same_namespace = "[[include]]\nfile = \"agent.toml\"\nrepeat = 2\nnamespace = \"agv\"\n";
    let dir = folder(&[("agent.toml", AGENT), ("top.toml", same_namespace)]);
    assert_refused(
        load(dir.path(), "top.toml", &[]),
        &["node agv/radar", "another copy of this include", "$(index)"],
    );
    let bad_namespace =
        "[[include]]\nfile = \"agent.toml\"\nrepeat = 2\nnamespace = \"$(index)\"\n";
    let dir = folder(&[("agent.toml", AGENT), ("top.toml", bad_namespace)]);
    assert_refused(
        load(dir.path(), "top.toml", &[]),
        &["include agent.toml (copy 1)", "namespace \"1\"", "segment"],
    );
}

#[test]
fn nested_include_namespaces_compose_outer_first_and_externals_follow() {
    let agent = r#"
[[external]]
topic = "/odom"
[[node]]
name = "association"
kind = "association"
namespace = "slam"
"#;
    let site = r#"
[[include]]
file = "agent.toml"
repeat = 2
namespace = "agv$(index)"
[include.params."slam/association"]
marker = "$(index)"
"#;
    let top = r#"
[[include]]
file = "site.toml"
namespace = "hall"
drop = ["agv1/slam/association"]
[include.params."agv2/slam/association"]
top = true
[[node]]
name = "fusion"
kind = "mapper"
"#;
    let dir = folder(&[
        ("agent.toml", agent),
        ("site.toml", site),
        ("top.toml", top),
    ]);
    let launch = load(dir.path(), "top.toml", &[]).unwrap();
    assert_eq!(names(&launch), ["hall/agv2/slam/association", "fusion"]);
    let node = &launch.nodes[0];
    assert_eq!(node.namespace, "hall/agv2/slam");
    assert_eq!(node.local_name(), "association");
    assert_eq!(node.params["marker"], toml::Value::Integer(2));
    assert_eq!(node.params["top"], toml::Value::Boolean(true));
    assert_eq!(launch.externals, ["/hall/agv1/odom", "/hall/agv2/odom"]);
    // Included nodes are named, in the includer's `params` and `drop`, as the included file
    // names them; an unknown one lists those.
    let wrong = top.replace(
        "drop = [\"agv1/slam/association\"]",
        "drop = [\"association\"]",
    );
    std::fs::write(dir.path().join("top.toml"), wrong).unwrap();
    assert_refused(
        load(dir.path(), "top.toml", &[]),
        &[
            "drop",
            "no node association",
            "agv1/slam/association, agv2/slam/association",
        ],
    );
}

#[test]
fn launches_without_namespaces_are_unchanged() {
    let text = "[[node]]\nname = \"radar\"\nkind = \"radar\"\n";
    let launch = parse(text, &["radar.frames:=5"]).unwrap();
    let radar = &launch.nodes[0];
    assert_eq!(
        (
            radar.name.as_str(),
            radar.namespace.as_str(),
            radar.remap.len()
        ),
        ("radar", "", 0)
    );
    assert_eq!(radar.local_name(), "radar");
}

#[test]
fn an_included_file_may_declare_only_externals_but_a_file_run_needs_a_node() {
    // What launch/cooperative.toml includes per remote AGV: topics, no node.
    let topics = "[[external]]\ntopic = \"/slam/keyframe\"\n[[external]]\ntopic = \"/slam/pose\"\n";
    let top = r#"
[[include]]
file = "topics.toml"
repeat = 2
namespace = "agv$(index)"
[[node]]
name = "fusion"
kind = "fusion"
"#;
    let dir = folder(&[("topics.toml", topics), ("top.toml", top)]);
    let launch = load(dir.path(), "top.toml", &[]).unwrap();
    assert_eq!(names(&launch), ["fusion"]);
    assert_eq!(
        launch.externals,
        [
            "/agv1/slam/keyframe",
            "/agv1/slam/pose",
            "/agv2/slam/keyframe",
            "/agv2/slam/pose"
        ]
    );
    assert_refused(load(dir.path(), "topics.toml", &[]), &["no node runs"]);
    let dir = folder(&[("empty.toml", "[arguments.a]\ndefault = 1\n")]);
    assert_refused(
        load(dir.path(), "empty.toml", &[]),
        &["no [[node]], [[include]] or [[external]] declared"],
    );
}
