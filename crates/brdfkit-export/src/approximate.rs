//! `--approximate`: the nearest material a target has, fitted to the model, with the
//! conversion's error stated.

use brdfkit_core::Rgb;
use brdfkit_fit::FitConfig;
use brdfkit_fit::families::FamilyFitError;
use brdfkit_fit::target::{TargetFit, fit_for};
use brdfkit_merl::Dims;
use brdfkit_models::lambert::Lambert;
use serde_json::{Value, json};

use crate::*;

/// The grid `--approximate` samples a model on: 45 × 45 × 90 cells of the MERL
/// parameterisation (its θh spacing dense near the specular peak), ~180,000 valid cells.
pub const APPROXIMATE_DIMS: (i64, i64, i64) = (45, 45, 90);

/// An export by `--approximate`.
#[derive(Debug, Clone)]
pub struct Approximated {
    /// The export (exact, or of the best fitted configuration, the conversion's error in
    /// its notes).
    pub exported: Exported,
    /// The fits, or `None` when the model was exported exactly.
    pub fit: Option<TargetFit>,
    /// The best fit's relative error: the RMS of the difference over the RMS of the
    /// model's values (the l2 loss of the fit over that of f = 0), cell-weighted.
    pub relative_l2: f64,
}

/// Exports exactly when the form takes the model; otherwise fits every configuration the
/// target has ([`brdfkit_fit::target`]) to the model's values on the
/// [`APPROXIMATE_DIMS`] grid (cells above the horizon, solid-angle weights of `cfg`),
/// exports the best by `cfg`'s loss and states the conversion error in the notes. Never
/// writes something else silently: an invalid description is still an error.
pub fn export_approximate(
    description: &Value,
    form: ExportForm,
    source_name: &str,
    cfg: &FitConfig,
) -> Result<Approximated, ExportError> {
    match export(description, form, source_name) {
        Ok(exported) => {
            return Ok(Approximated {
                exported,
                fit: None,
                relative_l2: 0.0,
            });
        }
        Err(e @ (ExportError::Model(_) | ExportError::PerChannel)) => return Err(e),
        Err(_) => {}
    }
    let model = brdfkit_models::from_json(description)?;
    let (a, b, c) = APPROXIMATE_DIMS;
    let dims = Dims::new(a, b, c).expect("a valid grid");
    let data =
        brdfkit_fit::synth::synth_data(&*model, dims, brdfkit_fit::synth::Coverage::AboveHorizon)
            .map_err(|source| FamilyFitError {
            label: model.name().into(),
            source,
        })?;
    let fit = fit_for(&data, form.target(), cfg, &())?;
    let best = fit.best();
    let zero = Lambert::new(Rgb::ZERO)?;
    let scale = brdfkit_fit::evaluate_losses([&zero, &zero, &zero], &data, cfg.get_weighting())
        .l2
        .overall;
    let l = &best.record.losses_full;
    let relative_l2 = if scale > 0.0 {
        l.l2.overall / scale
    } else {
        0.0
    };
    let mut exported = export(&best.params(), form, source_name)?;
    let note = format!(
        "approximation: `{}` is not exactly a {} material; fitted `{}` (best of {}) to it \
         over {} cells of a {a}x{b}x{c} grid: relative RMS error {:.3} %, {} loss {:.4e}",
        model.name(),
        form.target().name(),
        best.label,
        fit.outcomes
            .iter()
            .map(|o| o.label.as_str())
            .collect::<Vec<_>>()
            .join(", "),
        best.record.cells_full,
        100.0 * relative_l2,
        cfg.get_loss(),
        l.get(cfg.get_loss()).overall,
    );
    // The note goes into the text as every other note does, and first.
    exported = with_first_note(exported, form, &note);
    Ok(Approximated {
        exported,
        fit: Some(fit),
        relative_l2,
    })
}

/// `e` with `note` added before its other notes, in the text as well.
pub(crate) fn with_first_note(e: Exported, form: ExportForm, note: &str) -> Exported {
    let mut notes = vec![note.to_string()];
    notes.extend(e.notes.iter().cloned());
    let text = match form {
        ExportForm::MitsubaXml => {
            let marker = "<bsdf ";
            let at = e.text.find(marker).unwrap_or(0);
            format!(
                "{}<!-- note: {} -->\n{}",
                &e.text[..at],
                note.replace("--", "- -"),
                &e.text[at..]
            )
        }
        ExportForm::Pbrt => {
            let at = e.text.find('\n').map_or(0, |i| i + 1);
            format!("{}# note: {note}\n{}", &e.text[..at], &e.text[at..])
        }
        // JSON: the dict has no comments (stderr only); glTF's extras take the notes.
        ExportForm::MitsubaDict => e.text,
        ExportForm::Gltf => {
            let mut v: Value = serde_json::from_str(&e.text).expect("our own JSON");
            v["materials"][0]["extras"]["brdfkit"]["notes"] = json!(notes);
            serde_json::to_string_pretty(&v).expect("JSON of plain values") + "\n"
        }
    };
    Exported { text, notes }
}
