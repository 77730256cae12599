//! The finite-cylinder samplers' certification (`linlight_verify::cylinder_suite`, documented
//! there and in docs/cylinders.md, "Certification"): every technique passes every check on every
//! configuration and every required negative control is rejected. The verdict table is printed
//! (`cargo test --release -p linlight-verify --test cylinder_suite -- --nocapture`).

use linlight_verify::cylinder_suite;

#[test]
fn cylinder_samplers_certified_and_controls_rejected() {
    let r = cylinder_suite::run();
    cylinder_suite::print(&r);
    assert_eq!(r.samples, 400_000);
    assert_eq!(r.techniques.len(), 6 * r.cross_density.len());
    assert_eq!(r.statistical_tests, 48);
    assert!(r.cross_density.len() >= 8);
    let failed: Vec<String> = r
        .techniques
        .iter()
        .filter(|t| !t.passed)
        .map(|t| format!("{} / {}", t.config, t.technique))
        .chain(
            r.cross_density
                .iter()
                .filter(|x| !x.passed)
                .map(|x| format!("{} / gamito cross-density", x.config)),
        )
        .collect();
    assert!(failed.is_empty(), "failed: {failed:?}");
    let missed: Vec<String> = r
        .negative_controls
        .iter()
        .filter(|c| c.required && !c.rejected)
        .map(|c| format!("{} / {}", c.config, c.control))
        .collect();
    assert!(missed.is_empty(), "controls not rejected: {missed:?}");
    // Every kind of control is required somewhere and rejected there.
    for name in [
        "pdf x 1.01",
        "one Halley step",
        "line density",
        "gamito 1/Omega_rect",
        "gamito unextended",
        "ltc pdf x 1.01",
        "ltc per radius",
    ] {
        let n = r
            .negative_controls
            .iter()
            .filter(|c| c.control == name && c.required && c.rejected)
            .count();
        assert!(
            n >= 4,
            "{name}: rejected where required on {n} configurations"
        );
    }
    assert!(r.passed);
}
