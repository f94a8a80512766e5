//! Figures from small synthetic models: the numbers they mark, byte-for-byte golden SVGs
//! (`UPDATE_GOLDEN=1 cargo test -p reports` rewrites them), PNGs that decode and show text.

use std::path::{Path, PathBuf};

use estimator::{Battery, Eq8Form, MissionOptions, Model, Payload, Platform, PolyCurve, Segment};
use reports::{
    BatteryMassFigure, CatalogueFigure, Figure, LimitMarker, MeasuredFlight, MeasuredStep,
    NamedBattery, PayloadFigure, ThrustCurveFigure, TimelineFigure,
};

/// A quadratic per-rotor curve, 0–200 g: P(T) = 2 + 0.1·T + 0.0005·T² W, written in the scaled
/// basis t = (T − 100)/100.
fn curve() -> PolyCurve {
    // P = 2 + 0.1(100 + 100t) + 0.0005(100 + 100t)² = 17 + 20t + 5t²
    PolyCurve::new(&[17.0, 20.0, 5.0], 100.0, 100.0, (0.0, 200.0), Some(12.0)).unwrap()
}

fn model() -> Model<PolyCurve> {
    Model::new(
        curve(),
        Platform {
            structure_mass_kg: 0.3,
            avionics_power_w: 2.0,
            rotor_count: 4,
        },
    )
    .with_thrust_limit_kg(0.5)
}

fn battery(name: &str, mass_kg: f64, wh_per_kg: f64) -> NamedBattery {
    NamedBattery {
        name: name.to_owned(),
        battery: Battery::from_density(mass_kg, wh_per_kg).unwrap(),
    }
}

fn thrust_figure() -> ThrustCurveFigure {
    let measured = [0.0, 50.0, 100.0, 150.0, 200.0]
        .iter()
        .enumerate()
        .map(|(i, &t)| MeasuredStep {
            thrust_g: t,
            power_w: curve().eval_unchecked(t) + if i % 2 == 0 { 0.2 } else { -0.2 },
            power_std_w: Some(0.3),
        })
        .collect();
    ThrustCurveFigure {
        curve: curve(),
        measured,
        thrust_limit: Some(LimitMarker {
            per_rotor_g: 125.0,
            uncertainty_g: 2.0,
            supply_voltage_v: Some(9.0),
            note: None,
        }),
        source: Some("synthetic.csv".to_owned()),
        steps_label: "measured".to_owned(),
    }
}

fn battery_mass_figure() -> BatteryMassFigure {
    BatteryMassFigure::from_model(&model(), 150.0, &Payload::default()).unwrap()
}

fn catalogue_figure() -> CatalogueFigure {
    CatalogueFigure::rank(
        &model(),
        &Payload::default(),
        &[
            battery("light", 0.08, 150.0),
            battery("over the limit", 0.25, 150.0),
            battery("best", 0.15, 150.0),
            battery("beyond the curve", 0.6, 150.0),
        ],
    )
    .unwrap()
}

fn payload_figure() -> PayloadFigure {
    PayloadFigure::from_model(
        &model(),
        &[
            battery("pack A", 0.15, 150.0),
            battery("pack B", 0.1, 160.0),
        ],
        &[0.0, 5.0],
        &[
            MeasuredFlight {
                battery: "A".to_owned(),
                payload_mass_kg: 0.0,
                payload_power_w: 0.0,
                endurance_mean_min: 12.0,
                endurance_std_min: Some(0.4),
                samples: Some(4),
            },
            MeasuredFlight {
                battery: "pack B".to_owned(),
                payload_mass_kg: 0.05,
                payload_power_w: 5.0,
                endurance_mean_min: 8.0,
                endurance_std_min: None,
                samples: None,
            },
        ],
    )
    .unwrap()
}

fn timeline_figure() -> TimelineFigure {
    let plan = [
        Segment::Hover { duration_min: 2.0 },
        Segment::Attached { duration_min: 20.0 },
        Segment::HoverUntilEmpty,
    ];
    let b = battery("pack A", 0.15, 150.0);
    let (summary, outcomes) = model()
        .evaluate_mission_vec(
            &b.battery,
            &Payload::default(),
            &plan,
            &MissionOptions::default(),
        )
        .unwrap();
    TimelineFigure::from_mission(
        &b.name,
        "hover 2m; attach 20m; hover until empty",
        Eq8Form::Consistent,
        &summary,
        &outcomes,
    )
}

fn all() -> Vec<Figure> {
    vec![
        thrust_figure().into(),
        battery_mass_figure().into(),
        catalogue_figure().into(),
        payload_figure().into(),
        timeline_figure().into(),
    ]
}

fn golden_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden")
}

/// `UPDATE_GOLDEN=1` rewrites the golden SVGs; `PREVIEW_DIR=DIR` also writes each figure's PNG
/// there, to look at.
#[test]
fn svgs_match_the_golden_files() {
    let update = std::env::var_os("UPDATE_GOLDEN").is_some_and(|v| v == "1");
    let preview = std::env::var_os("PREVIEW_DIR").map(PathBuf::from);
    for f in all() {
        if let Some(dir) = &preview {
            f.write_png(&dir.join(format!("{}.png", f.stem()))).unwrap();
        }
        let svg = f.to_svg().unwrap();
        let path = golden_dir().join(format!("{}.svg", f.stem()));
        if update {
            std::fs::write(&path, &svg).unwrap();
            continue;
        }
        let want = std::fs::read_to_string(&path).unwrap_or_else(|e| {
            panic!(
                "{}: {e}; run UPDATE_GOLDEN=1 cargo test -p reports",
                path.display()
            )
        });
        if svg != want {
            let line = svg
                .lines()
                .zip(want.lines())
                .position(|(a, b)| a != b)
                .map_or(svg.lines().count().min(want.lines().count()), |i| i);
            panic!(
                "{} differs from {} from line {} on:\n got: {:?}\nwant: {:?}\n\
                 (if the change is intended: UPDATE_GOLDEN=1 cargo test -p reports)",
                f.stem(),
                path.display(),
                line + 1,
                svg.lines().nth(line),
                want.lines().nth(line)
            );
        }
    }
}

#[test]
fn rendering_is_deterministic() {
    let f = Figure::from(payload_figure());
    assert_eq!(f.to_svg().unwrap(), f.to_svg().unwrap());
    assert_eq!(f.to_png().unwrap(), f.to_png().unwrap());
}

#[test]
fn pngs_decode_at_the_figure_size_with_text_drawn() {
    for f in all() {
        let bytes = f.to_png().unwrap();
        let mut reader = png::Decoder::new(std::io::Cursor::new(bytes))
            .read_info()
            .unwrap();
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut buf).unwrap();
        assert_eq!((info.width, info.height), f.size_px(), "{}", f.stem());
        // The title is centred in the top 40 px: its glyphs make dark pixels there.
        let row = info.line_size;
        let dark = (0..40)
            .flat_map(|y| buf[y * row..(y + 1) * row].chunks(3))
            .filter(|p| p.iter().all(|&c| c < 100))
            .count();
        assert!(
            dark > 200,
            "{}: no title text drawn ({dark} dark px)",
            f.stem()
        );
    }
}

#[test]
fn figures_mark_the_model_numbers() {
    let m = model();
    let fig4 = battery_mass_figure();
    let opt = m.optimise_battery(150.0, &Payload::default()).unwrap();
    assert_eq!(fig4.ideal.battery_mass_kg, opt.ideal.battery_mass_kg);
    let realistic = fig4.realistic.unwrap();
    assert_eq!(
        realistic.battery_mass_kg,
        opt.realistic.unwrap().battery_mass_kg
    );
    assert!((fig4.limit_battery_mass_kg.unwrap() - 0.2).abs() < 1e-12);
    let svg = Figure::from(fig4.clone()).to_svg().unwrap();
    assert!(svg.contains(&format!(
        "ideal optimum: {:.3} kg, {:.2} min",
        fig4.ideal.battery_mass_kg, fig4.ideal.endurance_min
    )));
    assert!(svg.contains(&format!(
        "realistic optimum: {:.3} kg, {:.2} min",
        realistic.battery_mass_kg, realistic.endurance_min
    )));
    assert!(svg.contains("payload limit m_X = 0 at m_B = 0.200 kg"));

    let fig3 = Figure::from(thrust_figure()).to_svg().unwrap();
    assert!(fig3.contains("at 12.0 V"));
    assert!(fig3.contains("thrust limit at 9.0 V: 125.0 ± 2.0 g"));
    assert!(fig3.contains("residual (W)"));
    let s = thrust_figure().residual_summary().unwrap();
    assert_eq!(s.n_points, 5);
    assert!((s.rmse_w - 0.2).abs() < 1e-9);
}

#[test]
fn the_catalogue_ranks_over_limit_packs_at_zero() {
    let fig = catalogue_figure();
    let names: Vec<&str> = fig
        .ranking
        .iter()
        .map(|r| r.battery.name.as_str())
        .collect();
    assert_eq!(
        names,
        ["best", "light", "over the limit", "beyond the curve"]
    );
    let over = &fig.ranking[2];
    assert!(over.over_payload_limit && over.endurance_min == 0.0);
    assert!(over.unlimited_endurance_min.unwrap() > 0.0);
    let beyond = &fig.ranking[3];
    assert!(beyond.over_payload_limit && beyond.unlimited_endurance_min.is_none());
    assert_eq!(fig.ranking[0].rank, 1);
    let svg = Figure::from(fig).to_svg().unwrap();
    assert!(svg.contains("over the payload limit (would give"));
    assert!(svg.contains("beyond the measured thrust range"));
}

#[test]
fn payload_lines_end_at_each_batterys_payload_limit() {
    let fig = payload_figure();
    assert_eq!(fig.series.len(), 4);
    for s in &fig.series {
        let limit = 0.5 - 0.3 - s.battery.battery.mass_kg;
        assert!((s.payload_limit_kg.unwrap() - limit).abs() < 1e-12);
        assert!((s.points.last().unwrap().0 - limit).abs() < 1e-12);
        assert_eq!(s.points.first().unwrap().0, 0.0);
    }
    // "A" matches "pack A"; the estimate of "pack B" with 5 W is below the one without.
    assert!(fig.measured.iter().all(|c| c.estimate_min.is_some()));
    let err = fig.measured[0].error_pct().unwrap();
    assert!((err - (fig.series[0].points[0].1 - 12.0) / 12.0 * 100.0).abs() < 1e-9);
}

#[test]
fn the_timeline_follows_the_mission() {
    let t = timeline_figure();
    assert_eq!(t.segments.len(), 3);
    assert!(t.segments[0].hover && !t.segments[1].hover && t.segments[2].hover);
    assert!((t.segments[0].energy_start_wh - t.battery_energy_wh).abs() < 1e-12);
    for w in t.segments.windows(2) {
        assert!((w[0].end_min - w[1].start_min).abs() < 1e-12);
        assert!((w[0].energy_end_wh - w[1].energy_start_wh).abs() < 1e-12);
    }
    assert!(t.segments[2].energy_end_wh.abs() < 1e-9);
    assert!((t.segments[2].end_min - t.total_min).abs() < 1e-12);
    assert!(t.ran_out_at_min.is_none());
}

#[test]
fn measured_flights_read_from_a_table_with_line_numbers_in_errors() {
    let csv = "# flights\nbattery,payload_mass_kg,payload_power_w,endurance_mean_min,endurance_std_min\n\
               Battery-A,0,0,13.6,0.3\nBattery-B,0.05,5,8.1,\n";
    let t = import::Table::parse(csv.as_bytes(), "flights.csv").unwrap();
    let f = MeasuredFlight::from_table(&t).unwrap();
    assert_eq!(f.len(), 2);
    assert_eq!(f[0].endurance_std_min, Some(0.3));
    assert_eq!(f[1].endurance_std_min, None);
    assert!(f[0].matches("TP-2100-3S1P (Battery-A)"));
    assert!(!f[0].matches("TP-1320-3S1P (Battery-B)"));

    let bad = "battery,payload_mass_kg,payload_power_w,endurance_mean_min\nA,-1,0,10\n";
    let t = import::Table::parse(bad.as_bytes(), "flights.csv").unwrap();
    let e = MeasuredFlight::from_table(&t).unwrap_err().to_string();
    assert!(
        e.contains("flights.csv, line 2") && e.contains("payload_mass_kg"),
        "{e}"
    );
}

#[test]
fn a_figure_writes_svg_and_png_and_nothing_else() {
    let dir = tempfile::tempdir().unwrap();
    let w = Figure::from(catalogue_figure()).write(dir.path()).unwrap();
    assert_eq!(w.stem, "fig5-battery-ranking");
    assert!(w.svg.is_file() && w.png.is_file());
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
    let missing = dir.path().join("no/such/dir/x.svg");
    let e = Figure::from(catalogue_figure())
        .write_svg(&missing)
        .unwrap_err();
    assert!(e.to_string().contains("no/such/dir"), "{e}");
}
