//! The paper's full figure set and the HTML report: every file written, the report
//! self-contained, its numbers those of the reproduction.

use reports::{HTML_FILE, ReportInput, paper_figures};

fn assert_self_contained(html: &str) {
    for bad in [
        "http://", "https://", "file:", "<script", "<link", "<img", "@import", "url(",
    ] {
        assert!(
            !html.contains(bad),
            "the report refers outside itself: {bad:?}"
        );
    }
}

#[test]
fn the_papers_figures_and_report() {
    let r = paper::reproduce().unwrap();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("figures");
    let files = paper_figures(&r, &out).unwrap();
    let stems: Vec<&str> = files.figures.iter().map(|f| f.stem).collect();
    assert_eq!(
        stems,
        [
            "fig3-thrust-curve",
            "fig4-endurance-vs-battery-mass",
            "fig5-battery-ranking",
            "fig6-endurance-vs-payload",
            "fig7-mission-timeline"
        ]
    );
    assert_eq!(files.paths().len(), 11);
    for p in files.paths() {
        assert!(p.is_file(), "{} missing", p.display());
    }
    assert_eq!(files.html, out.join(HTML_FILE));
    let html = std::fs::read_to_string(&files.html).unwrap();
    assert_self_contained(&html);
    assert_eq!(html.matches("<svg").count(), 5);
    let ideal = r.optimum.ideal;
    let realistic = r.optimum.realistic.unwrap();
    for want in [
        format!(
            "ideal optimum: {:.3} kg, {:.2} min",
            ideal.battery_mass_kg, ideal.endurance_min
        ),
        format!(
            "realistic optimum: {:.3} kg, {:.2} min",
            realistic.battery_mass_kg, realistic.endurance_min
        ),
        format!("{:.2} min", r.battery_a.endurance_min),
        format!("{:.2} min", r.battery_b.endurance_min),
        format!(
            "Mission timeline: {:.2} min",
            r.table_i_consistent.total_min
        ),
        format!("{:.4} min", r.table_i_printed.total_min),
    ] {
        assert!(html.contains(&want), "report lacks {want:?}");
    }
}

#[test]
fn the_html_escapes_its_text() {
    let r = paper::reproduce().unwrap();
    let mut input = ReportInput::from_reproduction(&r).unwrap();
    input.title = "<script>alert(1)</script> & co".to_owned();
    input
        .provenance
        .push(("note".to_owned(), "a < b".to_owned()));
    input.energy_density_wh_per_kg = None;
    input.catalogue.clear();
    input.payload_study = None;
    input.mission = None;
    let dir = tempfile::tempdir().unwrap();
    let files = reports::write_report(&input, dir.path()).unwrap();
    assert_eq!(files.figures.len(), 1);
    let html = std::fs::read_to_string(&files.html).unwrap();
    assert!(html.contains("&lt;script&gt;alert(1)&lt;/script&gt; &amp; co"));
    assert!(html.contains("a &lt; b"));
    assert_self_contained(&html);
}

#[test]
fn an_impossible_mission_is_an_error_and_nothing_is_written() {
    let r = paper::reproduce().unwrap();
    let mut input = ReportInput::from_reproduction(&r).unwrap();
    if let Some(m) = input.mission.as_mut() {
        m.battery.battery = estimator::Battery::from_density(0.4, 164.0).unwrap();
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("never");
    let e = reports::write_report(&input, &out).unwrap_err();
    // The estimator's reason is the error's cause.
    let e = std::iter::successors(Some(&e as &dyn std::error::Error), |c| c.source())
        .map(ToString::to_string)
        .collect::<Vec<_>>()
        .join(": ");
    assert!(e.contains("exceeds the thrust limit"), "{e}");
    assert!(!out.exists());
}
