//! The progress events of a report and of the fits it reports on, recorded
//! (`brdfkit_core::progress::Recorder`): each family started, its fit planned, every
//! start ended, the family done; then the report's sections in the order it computes
//! them.

use brdfkit_core::Rgb;
use brdfkit_core::progress::{Event, Recorder};
use brdfkit_fit::FitData;
use brdfkit_fit::families::{Structure, families, fit_each};
use brdfkit_merl::{Dims, MerlTable};
use brdfkit_validate::html::{ModelFit, ReportOptions, build_report};

/// A Lambertian table of 8 × 8 × 16 cells (fitted in milliseconds).
fn table() -> MerlTable {
    let v = 0.5 / std::f64::consts::PI;
    MerlTable::from_fn(Dims::new(8, 8, 16).unwrap(), |_, _, _| {
        Some(Rgb::new(v, 0.8 * v, 0.6 * v))
    })
    .unwrap()
}

#[test]
fn families_and_a_report_send_their_events_in_order() {
    let t = table();
    let data = FitData::from_table(&t).unwrap();
    let fams = families("lambert,ward", &Structure::default()).unwrap();
    let cfg = brdfkit_fit::FitConfig::default().starts(2).unwrap();
    let rec = Recorder::new();
    let outcomes = fit_each(&data, &fams, &cfg, &rec).unwrap();

    // Per family: started, planned, each start ended once, done with its summary.
    let ev = rec.events();
    let mut at = 0;
    for (k, o) in outcomes.iter().enumerate() {
        assert!(
            matches!(&ev[at], Event::FamilyStarted { index, count: 2, label } if *index == k && *label == o.label),
            "{:?}",
            ev[at]
        );
        let end = at
            + ev[at..]
                .iter()
                .position(|e| matches!(e, Event::FamilyDone { .. }))
                .expect("a FamilyDone");
        let inner = &ev[at + 1..end];
        assert!(
            matches!(&inner[0], Event::FitPlanned(p) if p.starts == 2),
            "{:?}",
            inner[0]
        );
        let mut ended: Vec<usize> = inner
            .iter()
            .filter_map(|e| match e {
                Event::StartDone(d) => Some(d.start),
                _ => None,
            })
            .collect();
        ended.sort();
        assert_eq!(ended, [0, 1], "{inner:?}");
        match &ev[end] {
            Event::FamilyDone {
                index,
                summary: Some(s),
                ..
            } => {
                assert_eq!(*index, k);
                assert_eq!(s.loss_name, cfg.get_loss().to_string());
                assert_eq!(s.loss, o.record.losses_full.get(cfg.get_loss()).overall);
                assert_eq!(s.converged, o.record.converged);
            }
            e => panic!("{e:?}"),
        }
        at = end + 1;
    }
    assert_eq!(at, ev.len(), "nothing after the last family");

    let fits: Vec<ModelFit> = outcomes
        .iter()
        .map(|o| ModelFit::fitted(o).unwrap())
        .collect();
    let opts = ReportOptions {
        render: None,
        ..ReportOptions::default()
    };
    let rec = Recorder::new();
    build_report(&t, "lambert.binary", &fits, Some(&cfg), &opts, &rec).unwrap();
    let sections: Vec<Event> = [
        "fit quality: losses, bands, percentiles",
        "θh slices and residual maps",
        "albedo curves",
        "physical checks of the fitted models",
        "interactive panels: embedded grids",
        "charts and page",
    ]
    .map(|s| Event::Section(s.into()))
    .to_vec();
    assert_eq!(rec.events(), sections);
}
