//! `nrslam reproduce` writes every figure with its CSV; Fig. 4 shows what ET-GOPSA sees and
//! GOSPA does not.

mod common;
use common::*;

#[test]
fn quick_reproduce_writes_every_figure() {
    let dir = temp();
    let out = dir.path();
    let output = run(&[
        "reproduce",
        "--out",
        out.to_str().unwrap(),
        "--trials",
        "2",
        "--frames",
        "6",
    ]);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    for file in [
        "fig4.png",
        "fig4.csv",
        "fig6.png",
        "fig6.csv",
        "fig7.png",
        "fig7.csv",
        "fig5/map.png",
        "fig5/segments.png",
        "fig3/r0_a1/map.png",
        "fig3/r0.1_a5/segments.png",
    ] {
        assert!(out.join(file).exists(), "{file} missing");
    }
    let timing: serde_json::Value =
        serde_json::from_str(&read(&out.join("reproduce.json"))).expect("reproduce.json is JSON");
    assert_eq!(timing["trials"], 2);
    assert!(timing["wall_time_s"].as_f64().unwrap() > 0.0);
    assert_eq!(
        timing["wall_time_per_condition_s"]
            .as_object()
            .unwrap()
            .len(),
        5
    );
    let fig6 = read(&out.join("fig6.csv"));
    assert_eq!(
        fig6.lines().next().unwrap(),
        "time_s,5g,r0_a1,r0.1_a1,r0_a5,r0.1_a5"
    );
    assert_eq!(fig6.lines().count(), 7, "header + 6 steps");
    // Fig. 4: y1 and y2 are equally far from x1, so GOSPA cannot tell them apart; y1 is nearer
    // x2, so ET-GOPSA charges it confusion (the paper's eq. GOPSA_10).
    let fig4 = read(&out.join("fig4.csv"));
    let row = |label: &str| -> Vec<f64> {
        let line = fig4.lines().find(|l| l.starts_with(label)).unwrap();
        line.rsplit(',')
            .take(6)
            .map(|v| v.parse().unwrap())
            .collect::<Vec<_>>()
            .into_iter()
            .rev()
            .collect()
    };
    let (y1, y2) = (row("{y1},"), row("{y2},"));
    assert_eq!(y1[0], y2[0], "GOSPA equal");
    assert!(
        y1[1] > y2[1],
        "ET-GOPSA of y1 {} should exceed that of y2 {}",
        y1[1],
        y2[1]
    );
}
