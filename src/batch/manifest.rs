//! The batch manifest: JSON Lines, one job per line, an optional `{"defaults": {...}}` first
//! line, command-line overrides on top. Every error names the manifest line and the field, and
//! a bad line fails alone: [`parse`] returns one [`Entry`] per line, each a job or an error.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use serde::Deserialize;
use serde_json::Value;

use super::cameras::CameraSpec;
use crate::render::image::output::AOV_NAMES;
use crate::render::RenderPath;

/// Largest image side a manifest may ask for (the device limit is checked when rendering).
pub const MAX_SIDE: u32 = 16384;

/// Longest accepted job id, in bytes (it names a directory).
pub const MAX_ID_BYTES: usize = 200;

/// A manifest line that cannot become a job: where and why.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{manifest}:{line}: {}{message}", field.as_ref().map(|f| format!("field `{f}`: ")).unwrap_or_default())]
pub struct ManifestError {
    /// The manifest file (as given).
    pub manifest: String,
    /// 1-based line number.
    pub line: usize,
    /// The field at fault (`cameras[2].c2w`), when one is.
    pub field: Option<String>,
    /// What is wrong.
    pub message: String,
}

/// Output image format.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Format {
    /// Tonemapped sRGB PNG.
    #[default]
    Png,
    /// Linear HDR 32-bit float OpenEXR.
    Exr,
}

impl Format {
    /// File extension.
    pub fn extension(self) -> &'static str {
        match self {
            Self::Png => "png",
            Self::Exr => "exr",
        }
    }
}

/// Rendering path of a job (`"rt"` or `"hybrid"`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
pub enum Mode {
    /// Pure ray tracing.
    #[default]
    #[serde(rename = "rt")]
    RayTraced,
    /// Raster primary visibility, ray-traced secondary rays.
    #[serde(rename = "hybrid")]
    Hybrid,
}

impl From<Mode> for RenderPath {
    fn from(m: Mode) -> Self {
        match m {
            Mode::RayTraced => RenderPath::RayTraced,
            Mode::Hybrid => RenderPath::Hybrid,
        }
    }
}

/// Shading model. Only Whitted ray tracing exists in this build; a new model is one arm in
/// [`Shading::parse`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Shading {
    /// Whitted: direct light with shadow rays, perfect reflection and refraction.
    #[default]
    Whitted,
}

impl Shading {
    /// Parses a manifest value.
    pub fn parse(name: &str) -> Result<Self, String> {
        match name {
            "whitted" => Ok(Self::Whitted),
            other => Err(format!(
                "shading '{other}' is not supported by this build (supported: whitted)"
            )),
        }
    }
}

/// Environment lighting of a job: none (the default light rig or the file's lights, the
/// settings' background and ambient), or an equirectangular `.hdr`/`.exr` map (a path relative
/// to the manifest's folder), as `--environment`.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Environment {
    /// The field is absent: the built-in environment for a scene without lights
    /// ([`crate::environment::default_environment`]), none for a scene with lights.
    #[default]
    Default,
    /// No environment map (`null` or `"none"`): the default light rig or the file's lights.
    None,
    /// An environment map file.
    File(PathBuf),
    /// A built-in environment: `"studio"` or `"sky[:ELEVATION_DEG,AZIMUTH_DEG[,TURBIDITY]]"`.
    Builtin(String),
}

impl Environment {
    /// Parses a manifest value: `null`, `"none"` or a path, resolved against `base`.
    pub fn parse(value: &Value, base: &Path) -> Result<Self, String> {
        match value {
            Value::Null => Ok(Self::None),
            Value::String(s) if s == "none" => Ok(Self::None),
            Value::String(s) if s.is_empty() => Err("empty path".into()),
            Value::String(s) => match crate::environment::EnvironmentSource::parse(s) {
                Ok(crate::environment::EnvironmentSource::File(_)) => Ok(Self::File(base.join(s))),
                Ok(_) => Ok(Self::Builtin(s.clone())),
                Err(e) => Err(e.to_string()),
            },
            other => Err(format!(
                "environment {other} must be null, \"none\", \"studio\", \"sky[:ELEVATION_DEG,AZIMUTH_DEG[,TURBIDITY]]\" or the path of a .hdr or .exr file"
            )),
        }
    }
}

/// The fields a job line (or the defaults line) may carry; every one optional here so that
/// defaults and overrides merge field by field. Unknown fields are errors.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JobFields {
    /// Job id: names the output directory `DIR/<id>/`.
    pub id: Option<String>,
    /// glTF file; relative paths resolve against the manifest's folder.
    pub scene: Option<String>,
    /// Views (see [`CameraSpec`]); kept as JSON until resolved so errors name the camera.
    pub cameras: Option<Value>,
    /// Image width.
    pub width: Option<u32>,
    /// Image height.
    pub height: Option<u32>,
    /// Rendering path.
    pub mode: Option<Mode>,
    /// Shading model name (see [`Shading`]).
    pub shading: Option<String>,
    /// Samples per pixel.
    pub spp: Option<u32>,
    /// Environment (see [`Environment`]).
    pub environment: Option<Value>,
    /// AOVs written next to each view (see [`AOV_NAMES`]).
    pub aovs: Option<Vec<String>>,
    /// Output format.
    pub format: Option<Format>,
}

impl JobFields {
    /// `self` with every field `over` sets replaced.
    pub fn overridden_by(mut self, over: &JobFields) -> Self {
        macro_rules! take {
            ($($f:ident),*) => { $( if over.$f.is_some() { self.$f = over.$f.clone(); } )* };
        }
        take!(
            id,
            scene,
            cameras,
            width,
            height,
            mode,
            shading,
            spp,
            environment,
            aovs,
            format
        );
        self
    }
}

/// One job, resolved and checked.
#[derive(Clone, Debug)]
pub struct Job {
    /// 0-based line index in the manifest file (what sharding counts).
    pub line_index: usize,
    /// Job id (a safe directory name).
    pub id: String,
    /// Scene file, resolved against the manifest's folder.
    pub scene: PathBuf,
    /// Views.
    pub cameras: CameraSpec,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Rendering path.
    pub mode: Mode,
    /// Shading model.
    pub shading: Shading,
    /// Samples per pixel.
    pub spp: u32,
    /// Environment.
    pub environment: Environment,
    /// AOV names.
    pub aovs: Vec<String>,
    /// Output format.
    pub format: Format,
}

/// What one manifest line became.
#[derive(Clone, Debug)]
pub enum Entry {
    /// A job.
    Job(Box<Job>),
    /// The defaults line (line 1 only).
    Defaults,
    /// A blank line.
    Blank,
    /// A line that cannot run, with its id when it had a readable one.
    Invalid {
        /// Its id, if any.
        id: Option<String>,
        /// Why.
        error: ManifestError,
    },
}

/// A parsed manifest: one entry per line of the file, in order.
#[derive(Clone, Debug)]
pub struct Manifest {
    /// The manifest's path as given.
    pub path: PathBuf,
    /// One entry per line.
    pub entries: Vec<Entry>,
}

/// Reads and parses a manifest file. `overrides` (the command line's flags) win over both the
/// defaults line and every job line. Only an unreadable file is an error here; bad lines
/// become [`Entry::Invalid`].
pub fn read(path: &Path, overrides: &JobFields) -> std::io::Result<Manifest> {
    let text = std::fs::read_to_string(path)?;
    let base = path.parent().unwrap_or(Path::new(""));
    Ok(Manifest {
        path: path.to_path_buf(),
        entries: parse(&text, &path.display().to_string(), base, overrides),
    })
}

/// Parses manifest text; `name` goes into errors, `base` resolves relative scene paths.
pub fn parse(text: &str, name: &str, base: &Path, overrides: &JobFields) -> Vec<Entry> {
    let mut defaults = JobFields::default();
    let mut first_line_of: HashMap<String, usize> = HashMap::new();
    let mut entries = Vec::new();
    for (index, line) in text.lines().enumerate() {
        let err = |field: Option<&str>, message: String| ManifestError {
            manifest: name.to_string(),
            line: index + 1,
            field: field.map(str::to_string),
            message,
        };
        if line.trim().is_empty() {
            entries.push(Entry::Blank);
            continue;
        }
        let value: Value = match serde_json::from_str(line) {
            Ok(v) => v,
            Err(e) => {
                entries.push(Entry::Invalid {
                    id: None,
                    error: err(None, format!("not JSON: {e}")),
                });
                continue;
            }
        };
        if let Some(d) = value.as_object().and_then(|o| o.get("defaults")) {
            let entry = match (index, value.as_object().map(|o| o.len())) {
                (0, Some(1)) => match fields(d) {
                    Ok(f) if f.id.is_some() => Entry::Invalid {
                        id: None,
                        error: err(Some("defaults.id"), "ids cannot have a default".into()),
                    },
                    Ok(f) => {
                        defaults = f;
                        Entry::Defaults
                    }
                    Err((field, message)) => Entry::Invalid {
                        id: None,
                        error: err(Some(&format!("defaults.{field}")), message),
                    },
                },
                (0, _) => Entry::Invalid {
                    id: None,
                    error: err(None, "the defaults line holds only `defaults`".into()),
                },
                _ => Entry::Invalid {
                    id: None,
                    error: err(
                        Some("defaults"),
                        "defaults may only be given on the first line".into(),
                    ),
                },
            };
            entries.push(entry);
            continue;
        }
        let line_fields = match fields(&value) {
            Ok(f) => f,
            Err((field, message)) => {
                let id = value.get("id").and_then(Value::as_str).map(str::to_string);
                entries.push(Entry::Invalid {
                    id,
                    error: err(Some(&field), message),
                });
                continue;
            }
        };
        let merged = defaults
            .clone()
            .overridden_by(&line_fields)
            .overridden_by(overrides);
        let id = merged.id.clone();
        let entry = match resolve(index, merged, base) {
            Ok(job) => match first_line_of.get(&job.id) {
                Some(first) => Entry::Invalid {
                    id: Some(job.id.clone()),
                    error: err(
                        Some("id"),
                        format!("duplicate id '{}' (first used on line {first})", job.id),
                    ),
                },
                None => {
                    first_line_of.insert(job.id.clone(), index + 1);
                    Entry::Job(Box::new(job))
                }
            },
            Err((field, message)) => {
                // An id seen here is taken even if the rest of the line is bad, so that a
                // later line reusing it is still a duplicate.
                if let Some(id) = &id {
                    first_line_of.entry(id.clone()).or_insert(index + 1);
                }
                Entry::Invalid {
                    id,
                    error: err(Some(&field), message),
                }
            }
        };
        entries.push(entry);
    }
    entries
}

/// Deserialises a job object; on failure finds the field at fault by trying the fields one
/// by one (serde's message for the whole object does not say which field it was in).
fn fields(value: &Value) -> Result<JobFields, (String, String)> {
    let Some(object) = value.as_object() else {
        return Err((
            "(line)".into(),
            format!("expected a JSON object, got {value}"),
        ));
    };
    match JobFields::deserialize(value) {
        Ok(f) => Ok(f),
        Err(whole) => {
            for (key, v) in object {
                let single = Value::Object([(key.clone(), v.clone())].into_iter().collect());
                if let Err(e) = JobFields::deserialize(&single) {
                    return Err((key.clone(), e.to_string()));
                }
            }
            Err(("(line)".into(), whole.to_string()))
        }
    }
}

type FieldError = (String, String);

fn required<T>(v: Option<T>, field: &str) -> Result<T, FieldError> {
    v.ok_or_else(|| {
        (
            field.to_string(),
            "missing (give it on the line or in defaults)".into(),
        )
    })
}

/// Checks that `id` can name a directory on every platform rqr runs on.
pub fn check_id(id: &str) -> Result<(), String> {
    if id.is_empty() || id == "." || id == ".." {
        return Err(format!("'{id}' cannot name an output directory"));
    }
    if id.len() > MAX_ID_BYTES {
        return Err(format!("longer than {MAX_ID_BYTES} bytes"));
    }
    if let Some(c) = id.chars().find(|c| {
        matches!(c, '/' | '\\' | ':' | '*' | '?' | '"' | '<' | '>' | '|') || c.is_control()
    }) {
        return Err(format!(
            "'{id}' contains {c:?}, which cannot be in a directory name"
        ));
    }
    Ok(())
}

fn resolve(line_index: usize, f: JobFields, base: &Path) -> Result<Job, FieldError> {
    let id = required(f.id, "id")?;
    check_id(&id).map_err(|m| ("id".to_string(), m))?;
    let scene = required(f.scene, "scene")?;
    if scene.is_empty() {
        return Err(("scene".into(), "empty path".into()));
    }
    let scene = base.join(scene);
    let cameras = CameraSpec::from_json(&required(f.cameras, "cameras")?)
        .map_err(|(sub, m)| (format!("cameras{sub}"), m))?;
    let width = f.width.unwrap_or(512);
    let height = f.height.unwrap_or(512);
    for (name, v) in [("width", width), ("height", height)] {
        if v == 0 || v > MAX_SIDE {
            return Err((name.into(), format!("{v} is outside 1..={MAX_SIDE}")));
        }
    }
    let spp = f.spp.unwrap_or(1);
    if spp == 0 || spp > 4096 {
        return Err(("spp".into(), format!("{spp} is outside 1..=4096")));
    }
    let shading = match &f.shading {
        Some(s) => Shading::parse(s).map_err(|m| ("shading".to_string(), m))?,
        None => Shading::default(),
    };
    let environment = match &f.environment {
        Some(v) => Environment::parse(v, base).map_err(|m| ("environment".to_string(), m))?,
        None => Environment::default(),
    };
    let aovs = f.aovs.unwrap_or_default();
    for (k, a) in aovs.iter().enumerate() {
        if !AOV_NAMES.contains(&a.as_str()) {
            return Err((
                format!("aovs[{k}]"),
                format!("unknown AOV '{a}' (known: {})", AOV_NAMES.join(", ")),
            ));
        }
    }
    Ok(Job {
        line_index,
        id,
        scene,
        cameras,
        width,
        height,
        mode: f.mode.unwrap_or_default(),
        shading,
        spp,
        environment,
        aovs,
        format: f.format.unwrap_or_default(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const ORBIT: &str = r#""cameras": {"orbit": {"n": 2, "elevation_deg": [0, 30]}}"#;

    fn entries(text: &str) -> Vec<Entry> {
        parse(text, "m.jsonl", Path::new("/data"), &JobFields::default())
    }

    fn error(e: &Entry) -> &ManifestError {
        match e {
            Entry::Invalid { error, .. } => error,
            other => panic!("expected an error, got {other:?}"),
        }
    }

    #[test]
    fn defaults_apply_and_lines_and_overrides_win() {
        let text = format!(
            "{{\"defaults\": {{\"width\": 64, \"spp\": 4, \"scene\": \"a.glb\", {ORBIT}}}}}\n\
             {{\"id\": \"x\", \"spp\": 2}}\n\
             {{\"id\": \"y\", \"scene\": \"sub/b.gltf\", \"format\": \"exr\"}}\n"
        );
        let over = JobFields {
            height: Some(32),
            ..Default::default()
        };
        let e = parse(&text, "m.jsonl", Path::new("/data"), &over);
        assert!(matches!(e[0], Entry::Defaults));
        let Entry::Job(x) = &e[1] else {
            panic!("{e:?}")
        };
        assert_eq!((x.width, x.height, x.spp), (64, 32, 2));
        assert_eq!(x.scene, Path::new("/data/a.glb"));
        assert_eq!(x.line_index, 1);
        let Entry::Job(y) = &e[2] else {
            panic!("{e:?}")
        };
        assert_eq!((y.spp, y.format), (4, Format::Exr));
        assert_eq!(y.scene, Path::new("/data/sub/b.gltf"));
    }

    #[test]
    fn errors_name_the_line_and_the_field() {
        let text = format!(
            "not json\n\
             {{\"id\": \"a\", \"scene\": \"s.glb\", {ORBIT}, \"colour\": 1}}\n\
             {{\"id\": \"b\", \"scene\": \"s.glb\", {ORBIT}, \"width\": \"wide\"}}\n\
             {{\"id\": \"c\", {ORBIT}}}\n\
             {{\"id\": \"d\", \"scene\": \"s.glb\", {ORBIT}, \"shading\": \"path\"}}\n\
             {{\"id\": \"e\", \"scene\": \"s.glb\", {ORBIT}, \"environment\": 7}}\n\
             {{\"id\": \"f\", \"scene\": \"s.glb\", {ORBIT}, \"aovs\": [\"depth\", \"albedo\", \"emission\"]}}\n\
             {{\"id\": \"g\", \"scene\": \"s.glb\", {ORBIT}}}\n\
             {{\"id\": \"g\", \"scene\": \"s.glb\", {ORBIT}}}\n\
             {{\"id\": \"../up\", \"scene\": \"s.glb\", {ORBIT}}}\n\
             {{\"defaults\": {{\"spp\": 2}}}}\n"
        );
        let e = entries(&text);
        let cases: [(usize, Option<&str>, &str); 10] = [
            (0, None, "not JSON"),
            (1, Some("colour"), "unknown field `colour`"),
            (2, Some("width"), "invalid type"),
            (3, Some("scene"), "missing"),
            (4, Some("shading"), "not supported by this build"),
            (5, Some("environment"), "must be null"),
            (6, Some("aovs[2]"), "unknown AOV 'emission'"),
            (8, Some("id"), "duplicate id 'g' (first used on line 8)"),
            (9, Some("id"), "cannot be in a directory name"),
            (10, Some("defaults"), "first line"),
        ];
        for (index, field, needle) in cases {
            let err = error(&e[index]);
            assert_eq!(err.line, index + 1, "{err}");
            assert_eq!(err.field.as_deref(), field, "{err}");
            assert!(err.to_string().contains(needle), "{err}");
            assert!(err
                .to_string()
                .starts_with(&format!("m.jsonl:{}: ", index + 1)));
        }
        assert!(matches!(e[7], Entry::Job(_)));
    }

    #[test]
    fn shading_and_environment_accept_what_this_build_has() {
        assert_eq!(Shading::parse("whitted"), Ok(Shading::Whitted));
        let base = Path::new("dir");
        assert_eq!(
            Environment::parse(&Value::Null, base),
            Ok(Environment::None)
        );
        assert_eq!(
            Environment::parse(&Value::String("none".into()), base),
            Ok(Environment::None)
        );
        assert_eq!(
            Environment::parse(&Value::String("maps/studio.hdr".into()), base),
            Ok(Environment::File(PathBuf::from("dir/maps/studio.hdr")))
        );
        assert_eq!(
            Environment::parse(&Value::String("sky:20,90,4".into()), base),
            Ok(Environment::Builtin("sky:20,90,4".into()))
        );
        let bad = Environment::parse(&Value::String("sky:95,0".into()), base).unwrap_err();
        assert!(bad.contains("outside 0..90"), "{bad}");
    }

    #[test]
    fn blank_lines_are_kept_so_line_numbers_stay_put() {
        let e = entries(&format!(
            "\n{{\"id\": \"a\", \"scene\": \"s.glb\", {ORBIT}}}\n"
        ));
        assert!(matches!(e[0], Entry::Blank));
        let Entry::Job(j) = &e[1] else { panic!() };
        assert_eq!(j.line_index, 1);
    }
}
