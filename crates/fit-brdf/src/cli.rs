//! Command-line syntax (clap derive). Validation beyond syntax happens in `commands`.

use brdfkit::core::scattering::{Distribution, Masking};
use brdfkit::fit::batch::Shard;
use brdfkit::fit::families::FitSettings;
use brdfkit::fit::families::REPORT_MODELS;
use brdfkit::fit::{BsdfInput, FullIters, Loss, LossSet, RobustKind, SolverKind, Weighting};
use brdfkit::models::cook_torrance::FresnelKind;
use brdfkit::models::ward::Normalization;
use clap::builder::{ArgPredicate, PossibleValue, PossibleValuesParser, TypedValueParser};
use clap::{Args, Parser, Subcommand, ValueEnum};
use std::path::PathBuf;
use std::str::FromStr;

/// A structural choice on the command line: clap lists `names` (in --help, in the
/// completions and in the error for a bad value, exit 2) and the chosen name is parsed
/// with the type's `FromStr`.
fn choice<T>(names: impl IntoIterator<Item = &'static str>) -> impl TypedValueParser<Value = T>
where
    T: FromStr + Clone + Send + Sync + 'static,
    T::Err: Into<Box<dyn std::error::Error + Send + Sync + 'static>>,
{
    PossibleValuesParser::new(names).try_map(|s| s.parse::<T>())
}

/// The loss names, each also accepted with underscores (`low_e1`, as the records'
/// Python keys were once spelt; [`Loss::underscored`]), and `bbm-log`.
fn loss_choice() -> impl TypedValueParser<Value = Loss> {
    let values = Loss::EVERY.map(|l| {
        let v = PossibleValue::new(l.name());
        if l.underscored() == l.name() {
            v
        } else {
            v.alias(l.underscored())
        }
    });
    PossibleValuesParser::new(values.into_iter().chain([PossibleValue::new("bbm-log")]))
        .try_map(|s| s.parse::<Loss>())
}

/// The names of [`Weighting`] (which has no list of its variants).
const WEIGHTINGS: [&str; 2] = ["solid-angle", "uniform"];

#[derive(Parser, Debug)]
#[command(
    name = "fit-brdf",
    version,
    about = "Inspect, evaluate, resample, synthesise and fit measured BRDFs (MERL tables)",
    long_about = "fit-brdf works on MERL binary BRDF tables and on analytic models given as JSON \
                  ({\"model\": \"<name>\", \"params\": {...}}).\n\
                  Exit codes: 0 success, 1 runtime failure, 2 bad input or usage."
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Print a table's dims, valid fraction, per-channel statistics and albedo; or a
    /// `.bsdf` file's description, grids, negative values, measured points and asymmetry.
    #[command(
        after_help = "Examples:\n  fit-brdf info gold-metallic-paint.binary\n  fit-brdf info table.binary --json\n  \
                            fit-brdf info chm_mint_rgb.bsdf\n\n\
                            Every command that reads a table also reads an RGL-EPFL .bsdf file (recognised by its \
                            first bytes, not its name), resampled in memory to a 90x90x180 MERL table (docs/rgl.md)."
    )]
    Info(InfoArgs),
    /// Evaluate a table, a model, a neural BRDF or a `.bsdf` file at direction pairs (CSV
    /// or .npy).
    #[command(
        after_help = "Examples:\n  fit-brdf eval --table t.binary --dirs pairs.csv --interp linear --out values.csv\n  \
                            fit-brdf eval --model params.json --dirs pairs.csv\n  \
                            fit-brdf eval --table t.binary --dirs pairs.npy --out values.npy\n  \
                            fit-brdf eval --nbrdf data-measured/merl/red-fabric --dirs pairs.csv\n  \
                            fit-brdf eval --bsdf chm_mint_rgb.bsdf --dirs pairs.npy --out values.npy\n\n\
                            IN.csv: header wi_x,wi_y,wi_z,wo_x,wo_y,wo_z then one unit-vector pair per line \
                            (local frame, z = normal, both pointing away from the surface). \
                            IN.npy: the same six columns as an N×6 float64 array.\n\
                            OUT.csv: header r,g,b; f_r without the cosine; empty fields where the table has no valid sample. \
                            OUT.npy: an N×3 float64 array, NaN where the table has no valid sample."
    )]
    Eval(EvalArgs),
    /// Resample a table onto another grid, or write a model, a neural BRDF or a `.bsdf`
    /// file as a table.
    #[command(
        after_help = "Examples:\n  fit-brdf resample --table t.binary --dims 45,45,90 --out small.binary\n  \
                            fit-brdf resample --model params.json --dims 90,90,180 --out model.binary\n  \
                            fit-brdf resample --nbrdf data-measured/merl/red-fabric --dims 90,90,180 --out red-fabric.binary\n  \
                            fit-brdf resample --bsdf chm_mint_rgb.bsdf --dims 90,90,180 --out mint.binary\n\n\
                            A .bsdf cell holds the mean of f(wi, wo) and f(wo, wi) weighted by cos^2/(cos^2 + 0.1^2) of the \
                            direction each divides by, so an order near grazing does not dominate (the data are not \
                            reciprocal; the asymmetry is reported; docs/rgl.md); negative values are stored as 0 and counted."
    )]
    Resample(ResampleArgs),
    /// Generate the table of a synthetic material spec (data-synthetic/*.toml).
    #[command(
        after_help = "Example:\n  fit-brdf synth data-synthetic/red-plastic.toml --out red-plastic.binary"
    )]
    Synth(SynthArgs),
    /// Fit one or several analytic models to a table (nonlinear least squares).
    #[command(
        after_help = "Examples:\n  fit-brdf fit gold.binary --model cook-torrance --distribution ggx --fresnel schlick --out params.json\n  \
                            fit-brdf fit gold.binary --model lambert,plausible-phong,ward,lafortune,cook-torrance\n  \
                            fit-brdf fit t.binary --model my-start.json --loss log --starts 16 --record fit.json\n  \
                            fit-brdf fit gold.binary --for mitsuba --out gold.json     # then: export gold.json --to mitsuba\n\n\
                            --model takes model names or model JSON files (a start with fixed structural choices). \
                            With one model, --out is the fitted PARAMS.json; with several, a directory that receives \
                            <model>.json and <model>.fit.json for each. --for mitsuba|pbrt|gltf fits every configuration \
                            that renderer has (docs/export.md) and writes the best to --out. Losses and solvers: docs/fitting.md."
    )]
    Fit(FitArgs),
    /// Physical checks of a model (JSON) or a measured table: non-negativity,
    /// reciprocity, energy, isotropy, finiteness (models); coverage, negative and
    /// non-finite cells, the albedo curve (tables). Exit 1 when a check fails.
    #[command(
        after_help = "Examples:\n  fit-brdf check params.json\n  fit-brdf check gold.binary --json\n\n\
                            The input is read as a model when it is JSON (its first non-blank \
                            character is '{'), as a MERL table otherwise."
    )]
    Check(CheckArgs),
    /// Render a scene (TOML): only the light transport it declares (direct light,
    /// environment, shadows); the cost of each effect is reported.
    #[command(
        after_help = "Examples:\n  fit-brdf render examples/scenes/sphere-point.toml --out sphere.png\n  \
                            fit-brdf render examples/scenes/studio.toml --out studio.png --exr studio.exr --spp 64\n\n\
                            The format follows the extension of --out: .png (tone-mapped sRGB) or .exr (linear radiance). \
                            The scene format is in docs/rendering.md."
    )]
    Render(RenderArgs),
    /// Run the whole job on the embedded demo material (no downloads): synthesise its
    /// table, check it round-trips, fit five model families and write the fit-quality report.
    #[command(
        after_help = "Example:\n  fit-brdf demo --out demo-out      # then open demo-out/report/index.html"
    )]
    Demo(DemoArgs),
    /// Fit models to a table and write the fit-quality report: DIR/index.html (one
    /// self-contained page: summary, interactive views, θh slices, residual maps, rendered
    /// spheres, albedo, physical checks) and DIR/report.json; on a `.bsdf`'s points or
    /// scattered samples, the report on scattered data (nothing resampled).
    #[command(
        after_help = "Examples:\n  fit-brdf report gold.binary --out gold-report\n  \
                            fit-brdf report gold.binary --models lambert,cook-torrance --fresnel conductor --starts 4 --out r\n  \
                            fit-brdf report t.binary --json --quiet > summary.json\n  \
                            fit-brdf report gold.binary --given published.json --models cook-torrance --out r\n  \
                            fit-brdf report felt.bsdf --out r            # the measured points; spheres from the file\n  \
                            fit-brdf report --samples lab.csv --out r    # scattered samples, plotted where measured\n\n\
                            Every option of `fit` applies. The page opens from disk (no server). \
                            What each section shows and how to read it: docs/report.md."
    )]
    Report(ReportArgs),
    /// Fit every table of a directory or glob, one JSON per table plus a summary CSV;
    /// resumable, shardable over a job array, and interruptible without partial files.
    #[command(
        after_help = "Examples:\n  fit-brdf batch merl/ --models lambert,cook-torrance --fresnel conductor --out fits/\n  \
                            fit-brdf batch 'merl/*-paint.binary' --out fits/ --starts 4 --json\n  \
                            fit-brdf batch merl/ --out fits/ --shard 3/16     # one task of a 16-task job array\n  \
                            fit-brdf batch --nbrdf proxies/merl proxies/rgl-isotropic --models lafortune-2,cook-torrance-2 --out fits/\n\n\
                            Inputs: a directory (its *.binary and *.bsdf files), a glob pattern (quoted), or table files; \
                            a .bsdf (told by its first bytes) is fitted as --bsdf-input says (default: its measured points, as `fit`). \
                            Every option of `fit` applies. A table whose OUTDIR/<stem>.json exists and was made \
                            with the same options from the same table is skipped (resume); --force refits. \
                            --shard I/N takes the tables whose file name hashes to shard I (1-based); \
                            a shard that holds none of them says so and exits 0. \
                            Ctrl-C stops after the current table (twice: now); no partial file is left. \
                            Exit 1 when a table failed (the others are finished). Slurm and GNU parallel \
                            recipes: docs/batch.md."
    )]
    Batch(BatchArgs),
    /// Export a model as a renderer material: Mitsuba 3 (XML or dict), pbrt-v4 or glTF 2.0.
    #[command(
        after_help = "Examples:\n  fit-brdf export params.json --to mitsuba                  # <bsdf> XML on stdout\n  \
                            fit-brdf export params.json --to mitsuba --format dict --out bsdf.json\n  \
                            fit-brdf export params.json --to pbrt --out material.pbrt\n  \
                            fit-brdf export gltf.json --to gltf --out material.gltf     # from fit --for gltf\n  \
                            fit-brdf export ward.json --to mitsuba --approximate       # nearest material, error stated\n\n\
                            Supported: lambert -> diffuse; cook-torrance with conductor Fresnel and rho_d = 0 -> \
                            Mitsuba roughconductor (smith-separable; GGX, or Beckmann with beckmann_g1 = rational; \
                            rho_s -> specular_reflectance) or pbrt-v4 conductor (smith-correlated, GGX, rho_s = 1, \
                            alpha >= 1e-3); gltf-pbr -> glTF pbrMetallicRoughness. Anything else is an error \
                            (exit 2) saying what the target lacks, unless --approximate. `fit --for RENDERER` \
                            fits exactly what the renderer has. Details: docs/export.md."
    )]
    Export(ExportArgs),
    /// Print a shell completion script (bash, zsh, fish, elvish, powershell), or install
    /// it where the shell looks for it (--install).
    #[command(
        after_help = "Examples:\n  fit-brdf completions bash --install     # creates the folder if needed\n  \
                            fit-brdf completions zsh --install\n  \
                            fit-brdf completions fish --install\n  \
                            fit-brdf completions elvish > fit-brdf.elv\n\n\
                            --install writes bash's to ${XDG_DATA_HOME:-~/.local/share}/bash-completion/completions/fit-brdf, \
                            fish's to ${XDG_CONFIG_HOME:-~/.config}/fish/completions/fit-brdf.fish and zsh's to \
                            ~/.zfunc/_fit-brdf (zsh also needs `fpath=(~/.zfunc $fpath)` in ~/.zshrc before compinit). \
                            Redirecting by hand: create the folder first (mkdir -p)."
    )]
    Completions(CompletionsArgs),
    /// The accuracy-vs-time study: fit grids, evaluation choices and scaling on the
    /// synthetic materials; writes tables, CSV/JSON and PNG plots, and the report.
    #[command(
        after_help = "Examples:\n  fit-brdf study --out docs/accuracy-vs-time            # the full grid (long)\n  \
                            fit-brdf study --quick --out /tmp/study                # a CI-sized grid\n  \
                            fit-brdf study --parts measured --fits target/measured-fits   # docs/measured.md from a batch run\n  \
                            fit-brdf study --parts grid --models cook-torrance --solvers lm,lbfgs --fractions 0.02,1 --starts 1,4\n  \
                            fit-brdf study --parts grid --measured chrome-steel,pink-fabric   # the grid on measured proxies only\n\n\
                            Writes OUT/*.csv, OUT/*.json, OUT/*.png and OUT.md (only the generated sections between \
                            <!-- study:NAME --> markers are replaced; the rest of OUT.md is kept). Details: docs/accuracy-vs-time.md."
    )]
    Study(Box<StudyArgs>),
    /// Score given models against a table, a `.bsdf` or scattered samples without
    /// fitting: every loss (l2, cosine, cbrt, log) per channel and overall, on the cells
    /// and with the weights of `fit`.
    #[command(
        after_help = "Examples:\n  fit-brdf score gold.binary published.json\n  \
                            fit-brdf score gold.binary a.json b.json --weighting uniform --theta-d-max 80 --json\n  \
                            fit-brdf score felt.bsdf a.json              # at the file's measured points (--bsdf-input)\n  \
                            fit-brdf score --samples lab.csv a.json      # every positional file is a model\n\n\
                            MODEL.json: a model description ({\"model\": ..., \"params\": ...}), a per-channel fit \
                            ({\"per_channel\": [r, g, b]}) or a fit record (fit --record). The losses are those a fit \
                            with the same --weighting and --theta-d-max reports as losses_full, to the bit. \
                            Worked example with published parameters: docs/scoring.md."
    )]
    Score(ScoreArgs),
    /// Compare two representations of a material: every loss of B against A on A's
    /// valid cells, the largest relative differences with where they are, and the
    /// report's render pair and difference images.
    #[command(
        after_help = "Examples:\n  fit-brdf compare gold.binary gold-45.binary --resample linear\n  \
                            fit-brdf compare gold.binary data-measured/merl/gold-paint --out cmp/\n  \
                            fit-brdf compare gold.binary fit.json --json\n\n\
                            A and B are each recognised by their name: *.binary is a MERL table, *.json a model \
                            (or a per-channel fit, or a fit record), anything else DIR/NAME, the stem of the six \
                            NBRDF files NAME_{fc1,b1,fc2,b2,fc3,b3}.npy. A is the reference: a model or an NBRDF as A \
                            is tabulated on B's grid when B is a table, else on --dims. Two tables of different \
                            grids are refused (exit 2) unless --resample says how to bring B onto A's grid."
    )]
    Compare(CompareArgs),
    /// The report's interactive panels for any sources, overlaid, nothing fitted: one
    /// self-contained page (DIR/index.html) with the incidence plane, the θh–θd slice,
    /// the lit sphere and the directional albedo.
    #[command(
        after_help = "Examples:\n  fit-brdf view gold.binary --out gold-view\n  \
                            fit-brdf view gold.binary published.json fit.json --out cmp-view\n  \
                            fit-brdf view data-measured/merl/red-fabric cook-torrance.json --out v\n\n\
                            SOURCE is recognised by its name as in `compare`: *.binary a MERL table, *.json a model \
                            (or a per-channel fit, or a fit record), anything else DIR/NAME, the stem of an NBRDF's \
                            six .npy files. The first source is the reference of the slice's ratio and the sphere's \
                            difference. The page opens from disk (no server); what each panel shows and the \
                            precision of its embedded values: docs/report.md."
    )]
    View(ViewArgs),
}

#[derive(Args, Debug)]
pub struct ViewArgs {
    /// The sources: MERL tables, model descriptions (JSON), RGL-EPFL `.bsdf` files (each
    /// file's kind told by its first bytes), NBRDFs (DIR/NAME); the first is the
    /// reference.
    #[arg(required = true, value_name = "SOURCE")]
    pub sources: Vec<PathBuf>,
    /// Output directory (created if needed); index.html is replaced atomically.
    #[arg(long, value_name = "DIR", default_value = "brdf-view")]
    pub out: PathBuf,
    /// The page's title.
    #[arg(long)]
    pub title: Option<String>,
    /// Print nothing.
    #[arg(long, short)]
    pub quiet: bool,
}

#[derive(Args, Debug)]
pub struct InfoArgs {
    /// A MERL binary table, or an RGL-EPFL `.bsdf` file (recognised by its first bytes,
    /// `tensor_file`, whatever its name).
    pub table: PathBuf,
    /// Print machine-readable JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

/// Where values come from: a measured table, an analytic model or a neural BRDF.
#[derive(Args, Debug)]
#[group(required = true, multiple = false)]
pub struct Source {
    /// A MERL binary table.
    #[arg(long, value_name = "TABLE")]
    pub table: Option<PathBuf>,
    /// A model as JSON: `{"model": "<name>", "params": {...}}`.
    #[arg(long, value_name = "PARAMS.json")]
    pub model: Option<PathBuf>,
    /// A neural BRDF (NBRDF) of a measured material: DIR/NAME, the stem of the six files
    /// NAME_{fc1,b1,fc2,b2,fc3,b3}.npy (docs/measured.md).
    #[arg(long, value_name = "DIR/NAME")]
    pub nbrdf: Option<PathBuf>,
    /// An RGL-EPFL measured BSDF (`.bsdf`, a Mitsuba tensor file; docs/rgl.md),
    /// evaluated as Mitsuba 3's `measured` plugin does.
    #[arg(long, value_name = "F.bsdf")]
    pub bsdf: Option<PathBuf>,
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interp {
    /// The bin the direction pair falls in (the MERL reference lookup).
    Nearest,
    /// Multilinear interpolation between bins, missing cells left out.
    Linear,
}

#[derive(Args, Debug)]
pub struct EvalArgs {
    #[command(flatten)]
    pub source: Source,
    /// Direction pairs: a CSV file with the header wi_x,wi_y,wi_z,wo_x,wo_y,wo_z and one
    /// pair per line, or (by the .npy extension) an N×6 float64 array with the same
    /// columns. Directions must be unit vectors (within 1e-6).
    #[arg(long, value_name = "IN.csv|IN.npy")]
    pub dirs: PathBuf,
    /// Table lookup (ignored for models).
    #[arg(long, value_enum, default_value = "nearest")]
    pub interp: Interp,
    /// Output: CSV (header r,g,b; empty fields where there is no sample), or by the .npy
    /// extension an N×3 float64 array (NaN where there is no sample). Default: CSV on
    /// standard output.
    #[arg(long, value_name = "OUT.csv|OUT.npy")]
    pub out: Option<PathBuf>,
}

#[derive(Args, Debug)]
pub struct ResampleArgs {
    #[command(flatten)]
    pub source: Source,
    /// Target grid as θh,θd,φd bin counts, e.g. 90,90,180.
    #[arg(long, value_name = "A,B,C")]
    pub dims: String,
    /// Table lookup when resampling a table.
    #[arg(long, value_enum, default_value = "linear")]
    pub interp: Interp,
    /// Output table.
    #[arg(long, value_name = "NEW")]
    pub out: PathBuf,
    /// Print nothing but errors.
    #[arg(long, short)]
    pub quiet: bool,
}

#[derive(Args, Debug)]
pub struct SynthArgs {
    /// The spec (TOML).
    pub spec: PathBuf,
    /// Output table.
    #[arg(long, value_name = "TABLE")]
    pub out: PathBuf,
    /// Print nothing but errors.
    #[arg(long, short)]
    pub quiet: bool,
}

/// What a `.bsdf` input is fitted, scored or reported on (`fit`, `score`, `report`,
/// `batch`).
#[derive(Args, Debug, Clone, Copy)]
pub struct BsdfInputOption {
    /// What a `.bsdf` input is taken as: its measured points at their own directions
    /// (`points`), or its resampling to a 90 × 90 × 180 MERL table (`table`); the
    /// default and why: docs/rgl.md, "The sample-set fit".
    #[arg(long = "bsdf-input", value_name = "HOW", default_value = "points",
          value_parser = choice::<BsdfInput>(BsdfInput::ALL.map(BsdfInput::name)))]
    pub bsdf_input: BsdfInput,
}

/// The measurement `fit` and `report` work on: a table or `.bsdf` file, or scattered
/// samples (the library's one rule: `brdfkit::fit::input::Measured`).
#[derive(Args, Debug)]
pub struct MeasuredArgs {
    /// The measurement: a MERL binary table or an RGL-EPFL `.bsdf` file (told apart by
    /// their first bytes; a `.bsdf` is taken as `--bsdf-input` says).
    #[arg(required_unless_present = "samples", conflicts_with = "samples")]
    pub table: Option<PathBuf>,
    /// Scattered samples instead of a table: a `.npy` array (float32 or float64) or a
    /// CSV file, N rows of `wi_x,wi_y,wi_z,wo_x,wo_y,wo_z,r,g,b[,weight]`
    /// (docs/fitting.md, "Scattered samples"); `report` plots them at their own
    /// directions (docs/report.md).
    #[arg(long, value_name = "S.npy|S.csv")]
    pub samples: Option<PathBuf>,
    #[command(flatten)]
    pub bsdf: BsdfInputOption,
}

#[derive(Args, Debug)]
pub struct FitArgs {
    #[command(flatten)]
    pub input: MeasuredArgs,
    #[command(flatten)]
    pub opts: FitOptions,
    /// Fitted parameters (one model) or an output directory (several).
    #[arg(long, value_name = "PATH")]
    pub out: Option<PathBuf>,
    /// The fit record (one model only).
    #[arg(long, value_name = "FIT.json")]
    pub record: Option<PathBuf>,
    /// Fit exactly the configurations a renderer has (its free parameters free, e.g. a
    /// conductor's eta and k), pick the best by loss and write a model `export` takes.
    #[arg(long = "for", value_enum, value_name = "RENDERER",
          conflicts_with_all = ["model", "distribution", "masking", "fresnel", "normalization", "fix", "per_channel"])]
    pub for_renderer: Option<Renderer>,
    /// Print the results as JSON.
    #[arg(long)]
    pub json: bool,
    /// No progress bar, no summary on stderr.
    #[arg(long, short)]
    pub quiet: bool,
    /// Print where each fit's time went, stage by stage, on stderr (milliseconds;
    /// docs/performance.md).
    #[arg(long)]
    pub stage_times: bool,
}

/// The defaults of every fit option: the library's one set ([`FitSettings::default`]).
fn defaults() -> FitSettings {
    FitSettings::default()
}

/// The fit options shared by `fit` and `batch`: the models, their structural choices
/// and the solver settings, each a field of [`FitSettings`] with its default.
#[derive(Args, Debug, Clone)]
pub struct FitOptions {
    /// Comma-separated model names, or model JSON files (fitted from their parameters).
    #[arg(
        long,
        visible_alias = "models",
        value_name = "MODELS",
        default_value = brdfkit::models::named::DEFAULT_FAMILY
    )]
    pub model: String,
    /// Microfacet distribution of cook-torrance.
    #[arg(long, value_parser = choice::<Distribution>(Distribution::ALL.map(|v| v.name())))]
    pub distribution: Option<Distribution>,
    /// Masking of cook-torrance.
    #[arg(long, value_parser = choice::<Masking>(Masking::ALL.map(|v| v.name())))]
    pub masking: Option<Masking>,
    /// Fresnel term of cook-torrance (with the kind's default parameters).
    #[arg(long, value_parser = choice::<FresnelKind>(FresnelKind::ALL.map(|v| v.name())))]
    pub fresnel: Option<FresnelKind>,
    /// Normalisation of ward.
    #[arg(long, value_parser = choice::<Normalization>(Normalization::ALL.map(|v| v.name())))]
    pub normalization: Option<Normalization>,
    /// Loss optimised: brdfkit's l2, cosine, cbrt, log, or a published metric, ngan,
    /// low-e1, low-e2, bieron-log (bbm-log is log; docs/fitting.md).
    #[arg(long, default_value = defaults().loss.name(), value_parser = loss_choice())]
    pub loss: Loss,
    /// Losses reported: `own` (l2, cosine, cbrt, log) or `all` (and the four published
    /// metrics; always when one is optimised; `score` always reports all).
    #[arg(long, default_value = defaults().losses.name(), value_parser = choice::<LossSet>(LossSet::ALL.map(|v| v.name())))]
    pub losses: LossSet,
    #[command(flatten)]
    pub cells: CellOptions,
    /// Solver.
    #[arg(long, default_value = defaults().solver.name(), value_parser = choice::<SolverKind>(SolverKind::ALL.map(|v| v.name())))]
    pub solver: SolverKind,
    /// Number of starts (spread over the shape parameters, run in parallel).
    #[arg(long, default_value_t = defaults().starts)]
    pub starts: usize,
    /// How many of the starts continue on all cells after every start's warm-up on a
    /// subsample, the best by their loss there (the others stop; docs/fitting.md).
    #[arg(long, default_value_t = defaults().finish, value_name = "N")]
    pub finish: usize,
    /// Fit on this stratified fraction of the valid cells (losses are also reported on all).
    #[arg(long, default_value_t = defaults().sample_fraction)]
    pub sample_fraction: f64,
    /// Fit every parameter per channel independently (default: shape shared).
    #[arg(long)]
    pub per_channel: bool,
    /// Seed of the starts and the subsample.
    #[arg(long, default_value_t = defaults().seed)]
    pub seed: u64,
    /// Hold these parameters at their start values: comma-separated names or groups
    /// (`rho_d`, `alpha`, `rho_s.r`); the start is the model JSON given to --model, e.g.
    /// one with "rho_d": 0 to fit a pure conductor.
    #[arg(long, value_name = "NAMES", value_delimiter = ',')]
    pub fix: Option<Vec<String>>,
    /// Robust loss against outliers (see docs/fitting.md).
    #[arg(long, default_value = defaults().robust.name(), value_parser = choice::<RobustKind>(RobustKind::ALL.map(|v| v.name())))]
    pub robust: RobustKind,
    /// Scale c of the robust loss, in the loss's units (default: automatic, from the
    /// residuals of a plain fit: 1.4826 · median |e| times 1.345 (huber) or 2.385 (cauchy)).
    #[arg(long, value_name = "C")]
    pub robust_scale: Option<f64>,
    /// Keep the fitted model's directional albedo ≤ 1 (energy conservation, as a
    /// penalty on the albedo at fixed incidence angles; parameters such as rho_s are
    /// otherwise unbounded above; docs/fitting.md).
    #[arg(long)]
    pub energy_conserving: bool,
    /// LM iterations over all cells after a start's warm-up on a 65 536-cell stratified
    /// subsample (tables above 262 144 cells): 0 evaluates the warm-up optimum on all
    /// cells (Cook-Torrance: within 0.004 % of converging there on 15 measured tables;
    /// every default family within 0.14 % on the 7 vendored ones); `all` iterates to
    /// convergence; `auto` is 0, except `all` for Ward with Dür's normalisation, whose
    /// warm-up optimum lies up to 4.6 % above (docs/fitting.md).
    #[arg(long, default_value_t = defaults().full_iters, value_name = "N|all|auto")]
    pub full_iters: FullIters,
    /// Cells of the subsample every start explores before the starts are ranked (when
    /// there are more starts than --finish and the table is large enough for a warm-up).
    #[arg(long, default_value_t = brdfkit::fit::config::DEFAULT_EXPLORE_CELLS, value_name = "N")]
    pub explore_cells: usize,
}

/// Which cells the losses are taken over and how they are weighted: the options of
/// `fit` (through [`FitOptions`]) that `score` shares, so a score takes the cells and
/// weights of a fit.
#[derive(Args, Debug, Clone)]
pub struct CellOptions {
    /// Cell weights.
    #[arg(long, default_value = defaults().weighting.name(), value_parser = choice::<Weighting>(WEIGHTINGS))]
    pub weighting: Weighting,
    /// Ignore cells with θd above this angle (degrees): grazing data is the least reliable.
    #[arg(long, value_name = "DEG")]
    pub theta_d_max: Option<f64>,
    /// Ignore cells whose θi or θo exceeds this angle (degrees); Ngan et al. 2005 used 80.
    #[arg(long, value_name = "DEG")]
    pub theta_max: Option<f64>,
}

#[derive(Args, Debug)]
pub struct CheckArgs {
    /// A model description (JSON) or a MERL binary table.
    pub input: PathBuf,
    /// Print machine-readable JSON instead of text.
    #[arg(long)]
    pub json: bool,
    /// Print nothing; the exit code tells (0 all checks passed, 1 a check failed).
    #[arg(long, short)]
    pub quiet: bool,
}

#[derive(Args, Debug)]
pub struct RenderArgs {
    /// The scene (TOML).
    pub scene: PathBuf,
    /// Output image: .png (tone-mapped sRGB) or .exr (linear radiance).
    #[arg(long, value_name = "IMAGE")]
    pub out: PathBuf,
    /// Also write the linear radiance as EXR.
    #[arg(long, value_name = "IMAGE.exr")]
    pub exr: Option<PathBuf>,
    /// Override the scene's samples per pixel.
    #[arg(long)]
    pub spp: Option<usize>,
    /// Override the scene's resolution, as WIDTHxHEIGHT.
    #[arg(long, value_name = "WxH")]
    pub size: Option<String>,
    /// Print nothing but errors.
    #[arg(long, short)]
    pub quiet: bool,
    /// Print the per-effect cost as JSON on stdout.
    #[arg(long)]
    pub json: bool,
}

#[derive(Args, Debug)]
pub struct BatchArgs {
    /// Tables: directories (their *.binary files), glob patterns (quoted) or files.
    #[arg(required = true, value_name = "DIR_OR_GLOB")]
    pub inputs: Vec<String>,
    /// The inputs are neural BRDF proxies (six .npy files each): directories (every
    /// NAME with a NAME_fc1.npy), stems DIR/NAME or patterns; each is resampled onto
    /// the MERL grid in memory, no table is written.
    #[arg(long)]
    pub nbrdf: bool,
    #[command(flatten)]
    pub bsdf: BsdfInputOption,
    #[command(flatten)]
    pub opts: FitOptions,
    /// Output directory: `<stem>.json` per table and the summary CSV.
    #[arg(long, value_name = "OUTDIR")]
    pub out: PathBuf,
    /// Fit only shard I of N (1-based): the tables whose file name hashes to I.
    #[arg(long, value_name = "I/N")]
    pub shard: Option<Shard>,
    /// Refit tables that are already done.
    #[arg(long)]
    pub force: bool,
    /// Print the batch summary as JSON.
    #[arg(long)]
    pub json: bool,
    /// No progress bar and no per-table lines on stderr.
    #[arg(long, short)]
    pub quiet: bool,
}

/// A renderer or format `export` writes for and `fit --for` fits for.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Renderer {
    /// Mitsuba 3 (`diffuse`, `roughconductor`).
    Mitsuba,
    /// pbrt-v4 (`diffuse`, `conductor`).
    Pbrt,
    /// glTF 2.0 (`pbrMetallicRoughness` and the sheen, clearcoat, specular/ior extensions).
    Gltf,
}

impl Renderer {
    /// The library's fit target.
    pub fn target(self) -> brdfkit::fit::target::Target {
        use brdfkit::fit::target::Target;
        match self {
            Renderer::Mitsuba => Target::Mitsuba,
            Renderer::Pbrt => Target::Pbrt,
            Renderer::Gltf => Target::Gltf,
        }
    }
}

/// The form of a Mitsuba export.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExportFormat {
    /// A `<bsdf>` element (mitsuba.load_string, or paste into a scene file).
    Xml,
    /// A dictionary as JSON (json.load it, then mitsuba.load_dict).
    Dict,
}

/// What `export` writes for: a renderer's material, or an RGL-EPFL measured file.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExportTo {
    /// Mitsuba 3 (`diffuse`, `roughconductor`).
    Mitsuba,
    /// pbrt-v4 (`diffuse`, `conductor`).
    Pbrt,
    /// glTF 2.0 (`pbrMetallicRoughness`, from the `gltf-pbr` model).
    Gltf,
    /// An RGL-EPFL `.bsdf` file (Mitsuba 3's and pbrt-v4's `measured` material) from a
    /// MERL table, a model or an NBRDF.
    Rgl,
}

impl ExportTo {
    /// The renderer of a material export; `None` for the measured file.
    pub fn renderer(self) -> Option<Renderer> {
        match self {
            ExportTo::Mitsuba => Some(Renderer::Mitsuba),
            ExportTo::Pbrt => Some(Renderer::Pbrt),
            ExportTo::Gltf => Some(Renderer::Gltf),
            ExportTo::Rgl => None,
        }
    }
}

/// The value grid of an RGL-EPFL export (the database has both).
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum RglGrid {
    #[value(name = "32")]
    G32,
    #[value(name = "64")]
    G64,
}

#[derive(Args, Debug)]
pub struct ExportArgs {
    /// The model (JSON), e.g. the PARAMS.json written by `fit`; with `--to rgl` also a
    /// MERL table (`*.binary`) or an NBRDF (DIR/NAME).
    pub params: PathBuf,
    /// The renderer, or `rgl` for an RGL-EPFL `.bsdf` measured file.
    #[arg(long, value_enum)]
    pub to: ExportTo,
    /// `--to rgl`: the number of θi slices, uniform in √θ from 0 to 90° [default: 8, as
    /// the database's files].
    #[arg(long = "theta-i", value_name = "N",
          value_parser = clap::value_parser!(u16).range(2..=90))]
    pub theta_i: Option<u16>,
    /// `--to rgl`, anisotropic sources only: the number of φi slices over the stored φi
    /// range (a quarter, a half or the whole turn, by the source's symmetry; both ends
    /// included; at least 3: readers take 1 or 2 for isotropic) [default: one per 22.5°:
    /// 5, 9 or 17].
    #[arg(long = "phi-i", value_name = "N",
          value_parser = clap::value_parser!(u16).range(3..=64))]
    pub phi_i: Option<u16>,
    /// `--to rgl`: the value grid, 32 × 32 or 64 × 64 [default: 32].
    #[arg(long, value_enum)]
    pub grid: Option<RglGrid>,
    /// Mitsuba only: xml (default) or dict.
    #[arg(long, value_enum)]
    pub format: Option<ExportFormat>,
    /// When the model has no exact counterpart, fit the target's nearest material to it
    /// over the hemisphere and write that, with the conversion error in the notes.
    #[arg(long)]
    pub approximate: bool,
    /// Output file (default: standard output).
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// No notes on stderr.
    #[arg(long, short)]
    pub quiet: bool,
}

#[derive(Args, Debug)]
pub struct CompletionsArgs {
    /// The shell.
    #[arg(value_enum)]
    pub shell: clap_complete::Shell,
    /// Install the script where the shell looks for it (bash, zsh, fish), creating the
    /// folder, instead of printing it.
    #[arg(long)]
    pub install: bool,
}

#[derive(Args, Debug)]
pub struct DemoArgs {
    /// Directory for the demo's outputs.
    #[arg(long, default_value = "brdfkit-demo")]
    pub out: PathBuf,
    /// Run on the synthetic red plastic with known parameters (data-synthetic/
    /// demo-plastic.toml) instead of the measured specular-red-phenolic.
    #[arg(long)]
    pub synthetic: bool,
}

#[derive(Args, Debug)]
#[command(mut_arg("model", |a| a
    .default_value(REPORT_MODELS)
    // With --given alone nothing is fitted (an empty list).
    .default_value_if("given", ArgPredicate::IsPresent, Some(""))))]
pub struct ReportArgs {
    #[command(flatten)]
    pub input: MeasuredArgs,
    #[command(flatten)]
    pub opts: FitOptions,
    /// Models to report as given, not fitted (comma-separated JSON files: model
    /// descriptions, per-channel fits or fit records), beside the fits of --models; with
    /// --given and no --models, nothing is fitted.
    #[arg(long, value_name = "MODEL.json", value_delimiter = ',')]
    pub given: Vec<PathBuf>,
    /// Output directory (created if needed); index.html and report.json are replaced
    /// atomically.
    #[arg(long, value_name = "DIR", default_value = "fit-report")]
    pub out: PathBuf,
    #[command(flatten)]
    pub spheres: SphereOptions,
    /// Skip the physical checks of the fitted models.
    #[arg(long)]
    pub no_checks: bool,
    /// Print the report's summary (report.json's `summary`) as JSON on stdout.
    #[arg(long)]
    pub json: bool,
    /// No progress on stderr.
    #[arg(long, short)]
    pub quiet: bool,
}

/// The sphere renders of `report` and `compare`.
#[derive(Args, Debug)]
pub struct SphereOptions {
    /// Side of each rendered sphere image (pixels, 8 to 1024).
    #[arg(long, value_name = "PX", default_value_t = 128)]
    pub render_size: usize,
    /// Samples per pixel of the environment renders.
    #[arg(long, value_name = "N", default_value_t = 16)]
    pub env_spp: usize,
    /// Skip the sphere renders.
    #[arg(long)]
    pub no_renders: bool,
}

#[derive(Args, Debug)]
pub struct ScoreArgs {
    /// The measurement to score against (a MERL binary table or an RGL-EPFL `.bsdf`
    /// file, by their first bytes; none with `--samples`), then the models (JSON), each
    /// scored on its own.
    #[arg(required = true, value_name = "TABLE MODEL.json")]
    pub files: Vec<PathBuf>,
    /// Score on scattered samples (the format of `fit --samples`) instead of a table:
    /// every positional file is then a model.
    #[arg(long, value_name = "S.npy|S.csv")]
    pub samples: Option<PathBuf>,
    #[command(flatten)]
    pub bsdf: BsdfInputOption,
    #[command(flatten)]
    pub cells: CellOptions,
    /// Print the scores as JSON.
    #[arg(long)]
    pub json: bool,
}

#[derive(Args, Debug)]
pub struct CompareArgs {
    /// The reference: a MERL table, a model description (JSON), an RGL-EPFL `.bsdf` or
    /// an NBRDF (DIR/NAME). A file's kind is told by its first bytes, not its name.
    pub a: PathBuf,
    /// The representation compared with it (same kinds; a `.bsdf` as the mean of both
    /// orders of each pair, as `resample --bsdf` writes it).
    pub b: PathBuf,
    #[command(flatten)]
    pub cells: CellOptions,
    /// Bring a table B of another grid onto A's by resampling it (never done
    /// otherwise).
    #[arg(long, value_enum, value_name = "LOOKUP")]
    pub resample: Option<Interp>,
    /// The grid a model, an NBRDF or a `.bsdf` A is tabulated on when B is not a table.
    #[arg(long, value_name = "A,B,C", default_value = "90,90,180")]
    pub dims: String,
    /// How many of the largest relative differences to list.
    #[arg(long, value_name = "N", default_value_t = 10)]
    pub top: usize,
    /// Write the render pair and difference images (PNG) and compare.json here.
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    #[command(flatten)]
    pub spheres: SphereOptions,
    /// Print the comparison as JSON.
    #[arg(long)]
    pub json: bool,
}

/// A part of the study.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum StudyPart {
    /// The accuracy-vs-time grid.
    Grid,
    /// The structural choices.
    Choices,
    /// The scale figures.
    Scale,
    /// The whole measured database fitted and ranked, from a `batch --nbrdf` run
    /// (`--fits`): docs/measured.md, its CSV files, ranking figure and thumbnails.
    Measured,
    /// Measured proxies fitted with each loss, table and fits rendered and scored
    /// (ΔE2000, RMSE): docs/losses.md, its CSV and contact sheet.
    Losses,
}

#[derive(Args, Debug)]
pub struct StudyArgs {
    /// Output directory of the data and plots; the report is OUT.md.
    #[arg(long, default_value = "docs/accuracy-vs-time")]
    pub out: PathBuf,
    /// Directory of the material specs.
    #[arg(long, default_value = "data-synthetic")]
    pub specs: PathBuf,
    /// The CI-sized grid (2 materials, Cook-Torrance, LM / L-BFGS / Nelder-Mead, 2 % and 100 %, 1 and 4 starts).
    #[arg(long)]
    pub quick: bool,
    /// Parts to run (comma-separated).
    #[arg(
        long,
        value_name = "PARTS",
        value_enum,
        value_delimiter = ',',
        default_value = "grid,choices,scale"
    )]
    pub parts: Vec<StudyPart>,
    /// Synthetic materials (spec file stems), comma-separated; default: the grid's
    /// (given alone, without --measured: no measured material in the grid).
    #[arg(long)]
    pub materials: Option<String>,
    /// Measured materials of the grid: names of NBRDF proxies in --measured-dir,
    /// comma-separated; default: the grid's (given alone, without --materials: no
    /// synthetic material in the grid).
    #[arg(long)]
    pub measured: Option<String>,
    /// Directory of the proxies (searched with its subfolders) and of their
    /// reference-fits.json; default: $BRDFKIT_MEASURED_DIR, else `data-measured/` in the
    /// current folder or the nearest one above it, else the checkout fit-brdf was built
    /// from.
    #[arg(long, value_name = "DIR")]
    pub measured_dir: Option<PathBuf>,
    /// Models: cook-torrance, ward, plausible-phong, lambert, blinn-phong, lafortune.
    #[arg(long)]
    pub models: Option<String>,
    /// Solvers (comma-separated).
    #[arg(long, value_name = "SOLVERS", value_delimiter = ',',
          value_parser = choice::<SolverKind>(SolverKind::ALL.map(|v| v.name())))]
    pub solvers: Option<Vec<SolverKind>>,
    /// Sample fractions in (0, 1], e.g. 0.005,0.02,0.1,0.5,1.
    #[arg(long)]
    pub fractions: Option<String>,
    /// Numbers of starts, e.g. 1,4,16.
    #[arg(long)]
    pub starts: Option<String>,
    /// Largest fraction Nelder-Mead runs on.
    #[arg(long)]
    pub nelder_mead_max_fraction: Option<f64>,
    /// Iteration cap per start and stage of lm, gauss-newton, trust-region, lbfgs (the full grid: 25; 0 = each solver's own).
    #[arg(long)]
    pub max_iters: Option<u64>,
    /// Iteration cap per start of nelder-mead (the full grid: 1000; 0 = its own, 5000).
    #[arg(long)]
    pub nelder_mead_max_iters: Option<u64>,
    /// Several starts only where starts × fraction ≤ this (Nelder-Mead: a quarter);
    /// the full grid: 0.4; 0 = no limit.
    #[arg(long)]
    pub starts_budget: Option<f64>,
    /// Keep the fits of an interrupted run (OUT/grid-partial.json) and run only the rest.
    #[arg(long)]
    pub resume: bool,
    /// The fit grid ignores cells whose θi or θo exceeds this angle (degrees).
    #[arg(long, value_name = "DEG")]
    pub theta_max: Option<f64>,
    /// Timed repetitions of each evaluation figure.
    #[arg(long)]
    pub reps: Option<usize>,
    /// Tables in the batch-throughput figure.
    #[arg(long)]
    pub batch_tables: Option<usize>,
    /// Redraw the plots and rewrite OUT.md from OUT/results.json and OUT/run.json,
    /// measuring nothing.
    #[arg(long)]
    pub rewrite: bool,
    /// The measured part: the output directory of the `fit-brdf batch --nbrdf` run.
    #[arg(long, value_name = "DIR", default_value = "target/measured-fits")]
    pub fits: PathBuf,
    /// The measured part: `name,database,category` of every proxy.
    #[arg(
        long,
        value_name = "CSV",
        default_value = "data-measured/categories.csv"
    )]
    pub categories: PathBuf,
    /// The measured part: the document (its data and images go to the directory of the
    /// same name without `.md`).
    #[arg(long, value_name = "MD", default_value = "docs/measured.md")]
    pub measured_doc: PathBuf,
    /// The measured part: thumbnails of this many best and worst fitted materials.
    #[arg(long, value_name = "N", default_value_t = 3)]
    pub thumbnails: usize,
    /// The losses part: root of the proxies (`<root>/<database>/<name>`).
    #[arg(long, value_name = "DIR", default_value = "../shared/measured-proxies")]
    pub proxies: PathBuf,
    /// The losses part: proxies (comma-separated names; default: 25 across databases and
    /// categories).
    #[arg(long, value_name = "NAMES")]
    pub loss_materials: Option<String>,
    /// The losses part: model families (comma-separated `--model` names).
    #[arg(long, value_name = "MODELS", default_value = brdfkit::models::named::DEFAULT_FAMILY)]
    pub loss_models: String,
    /// The losses part: the document (its data and images go to the directory of the
    /// same name without `.md`).
    #[arg(long, value_name = "MD", default_value = "docs/losses.md")]
    pub losses_doc: PathBuf,
    /// The losses part: the grid the proxies are resampled onto.
    #[arg(long, value_name = "A,B,C", default_value = "90,90,180")]
    pub loss_dims: String,
    /// The losses part: render size (pixels) and samples per pixel under the
    /// environment (the report's: 128, 16).
    #[arg(long, value_name = "PX,SPP", default_value = "128,16")]
    pub loss_render: String,
    /// The losses part: starts per fit.
    #[arg(long, value_name = "N", default_value_t = 8)]
    pub loss_starts: usize,
    /// No progress lines on stderr.
    #[arg(long, short)]
    pub quiet: bool,
}
