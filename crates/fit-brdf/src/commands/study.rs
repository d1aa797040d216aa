//! `fit-brdf study`: the accuracy-vs-time study (`brdfkit-study`), with its grid taken
//! from the options.

use crate::cli::{StudyArgs, StudyPart};
use crate::error::{CliResult, bad_msg, runtime};
use brdfkit_study::grid::find_measured_dir_here;
use brdfkit_study::losses::LossesConfig;
use brdfkit_study::measured::MeasuredConfig;
use brdfkit_study::{ModelChoice, StudyConfig, StudyError};

fn list<T>(opt: &str, s: &str, parse: impl Fn(&str) -> Option<T>) -> CliResult<Vec<T>> {
    s.split(',')
        .map(str::trim)
        .filter(|x| !x.is_empty())
        .map(|x| parse(x).ok_or_else(|| bad_msg(format!("--{opt}: `{x}` is not valid"))))
        .collect()
}

/// The configuration the options ask for.
pub fn config(a: &StudyArgs) -> CliResult<StudyConfig> {
    let mut c = if a.quick {
        StudyConfig::quick(&a.out, &a.specs)
    } else {
        StudyConfig::full(&a.out, &a.specs)
    };
    let mut custom = false;
    let names = |opt, m: &Option<String>| {
        m.as_deref()
            .map(|m| list(opt, m, |x| Some(x.to_string())))
            .transpose()
    };
    // One set named alone is the whole grid; neither: the grid's own.
    match (
        names("materials", &a.materials)?,
        names("measured", &a.measured)?,
    ) {
        (None, None) => {}
        (syn, meas) => {
            c.materials = syn.unwrap_or_default();
            c.measured = meas.unwrap_or_default();
            custom = true;
        }
    }
    // Not given: found from the current folder (the README's tour runs in `tour/`);
    // none found: the default stays, and a measured material names --measured-dir.
    c.measured_dir =
        (a.measured_dir.clone().or_else(find_measured_dir_here)).unwrap_or(c.measured_dir);
    if let Some(m) = &a.models {
        c.models = list("models", m, ModelChoice::by_label)?;
        custom = true;
    }
    if let Some(s) = &a.solvers {
        c.solvers = s.clone();
        custom = true;
    }
    if let Some(f) = &a.fractions {
        c.fractions = list("fractions", f, |x| x.parse().ok())?;
        custom = true;
    }
    if let Some(s) = &a.starts {
        c.starts = list("starts", s, |x| x.parse().ok())?;
        custom = true;
    }
    c.nelder_mead_max_fraction = a
        .nelder_mead_max_fraction
        .unwrap_or(c.nelder_mead_max_fraction);
    // 0 lifts a cap (the solver's own default applies).
    let cap = |v: Option<u64>, d: Option<u64>| match v {
        Some(0) => None,
        Some(n) => Some(n),
        None => d,
    };
    c.max_iters = cap(a.max_iters, c.max_iters);
    c.nelder_mead_max_iters = cap(a.nelder_mead_max_iters, c.nelder_mead_max_iters);
    c.starts_budget = (a.starts_budget).map_or(c.starts_budget, |b| (b > 0.0).then_some(b));
    c.resume = a.resume;
    c.theta_max_deg = a.theta_max;
    c.reps = a.reps.unwrap_or(c.reps);
    c.batch_tables = a.batch_tables.unwrap_or(c.batch_tables);
    c.grid = a.parts.contains(&StudyPart::Grid);
    c.choices = a.parts.contains(&StudyPart::Choices);
    c.scale = a.parts.contains(&StudyPart::Scale);
    if custom {
        c.grid_name = format!("custom ({})", c.grid_name);
    }
    c.validate().map_err(|e| bad_msg(e.to_string()))?;
    Ok(c)
}

/// The loss comparison the options ask for.
fn losses_config(a: &StudyArgs) -> CliResult<LossesConfig> {
    let mut c = LossesConfig::new(&a.proxies, &a.categories);
    if let Some(m) = &a.loss_materials {
        c.materials = list("loss-materials", m, |x| Some(x.to_string()))?;
    }
    c.models = list("loss-models", &a.loss_models, |x| Some(x.to_string()))?;
    c.dims = super::parse_dims(&a.loss_dims)?;
    match list("loss-render", &a.loss_render, |x| x.parse::<usize>().ok())?[..] {
        [size, spp] if size > 0 && spp > 0 => (c.render.size, c.render.env_spp) = (size, spp),
        _ => return Err(bad_msg("--loss-render: expected PX,SPP, both positive")),
    }
    if a.loss_starts == 0 {
        return Err(bad_msg("--loss-starts: at least 1"));
    }
    c.starts = a.loss_starts;
    c.report = a.losses_doc.clone();
    c.out = a.losses_doc.with_extension("");
    Ok(c)
}

pub fn run(a: StudyArgs) -> CliResult<()> {
    let quiet = a.quiet;
    let progress = crate::progress::Progress::new(quiet);
    if a.rewrite {
        return brdfkit_study::rewrite(&a.out, &progress).map_err(|e| bad_msg(e.to_string()));
    }
    let study_error = |e: StudyError| match (&e, e.is_bad_input()) {
        (StudyError::Config { option, .. }, _) => bad_msg(format!("{e} (here: --{option})")),
        (_, true) => bad_msg(e.to_string()),
        (_, false) => runtime(e),
    };
    if a.parts.contains(&StudyPart::Measured) {
        let (fits, doc) = (a.fits.clone(), a.measured_doc.clone());
        let m = MeasuredConfig::new(fits, doc, a.categories.clone(), a.thumbnails);
        brdfkit_study::measured::run(&m, &progress).map_err(study_error)?;
    }
    if a.parts.contains(&StudyPart::Losses) {
        brdfkit_study::losses::run(&losses_config(&a)?, &progress).map_err(study_error)?;
    }
    if a.parts
        .iter()
        .all(|p| matches!(p, StudyPart::Measured | StudyPart::Losses))
    {
        return Ok(());
    }
    let cfg = config(&a)?;
    brdfkit_study::run(&cfg, &progress).map_err(study_error)?;
    if !quiet {
        eprintln!(
            "study: wrote {} and {}",
            cfg.out.display(),
            cfg.report_path().display()
        );
    }
    Ok(())
}
