//! Scene uploads (`multipart/form-data` on `POST /api/jobs`): a `job` part (the JSON settings,
//! as the JSON body but without `scene`/`scene_name`), then either a `scene` part (the scene:
//! candela JSON, or a file of another format of docs/import.md, recognised by its file name or
//! content) plus one part per asset file, named by its path relative to the scene (`-F
//! assets/wood.png=@wood.png`), or an `archive` part: a .tar, .tar.gz or .zip of the scene
//! folder with `scene.json` — or one scene file of another format — at its root (or inside its
//! single top-level folder).
//!
//! Everything is unpacked into a fresh folder under `<data>/tmp`, with every path checked (no
//! absolute paths, no `..`, no links) and the total size and file count limited, before the
//! scene is loaded; the folder is removed on any failure. A scene of another format is imported
//! there (`import_scene`) and stored as the candela JSON it means, with the meshes and images it
//! held inline written beside it, so a job's scene is always candela JSON.

use std::io::{Read, Write};
use std::path::{Component, Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use axum::extract::multipart::{Field, MultipartError};
use axum::extract::Multipart;
use tokio::io::AsyncWriteExt;

use super::request::{parse_request, JobRequest};
use crate::api_error::ApiError;
use crate::config::RequestLimits;

/// A folder removed when dropped (unless it was moved away).
#[derive(Debug)]
pub struct TempDir(pub PathBuf);

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// What an upload carried.
#[derive(Debug)]
pub struct Upload {
    /// The `job` part (defaults when absent).
    pub job: JobRequest,
    /// The scene JSON text (imported when the upload was another format).
    pub scene_json: String,
    /// The importer's warnings (`--lenient`), one line each.
    pub warnings: Vec<String>,
    /// The scene's base folder (inside `_root`).
    pub base: PathBuf,
    /// The temporary folder holding everything; removed on drop.
    pub _root: TempDir,
}

fn multipart_error(e: MultipartError) -> ApiError {
    if e.status() == axum::http::StatusCode::PAYLOAD_TOO_LARGE {
        ApiError::PayloadTooLarge(format!("upload: {}", e.body_text()))
    } else {
        ApiError::BadRequest {
            code: "invalid_multipart",
            message: format!("upload: {}", e.body_text()),
        }
    }
}

fn too_large(limits: &RequestLimits) -> ApiError {
    ApiError::PayloadTooLarge(format!(
        "upload: the files add up to more than {} bytes or {} files",
        limits.max_upload_bytes, limits.max_upload_files
    ))
}

/// A path inside the upload: relative, only plain components, at most 32 deep.
pub fn safe_relative(name: &str) -> Option<PathBuf> {
    if name.is_empty() || name.len() > 1024 || name.contains('\0') || name.contains('\\') {
        return None;
    }
    let mut out = PathBuf::new();
    for c in Path::new(name).components() {
        match c {
            Component::Normal(p) => out.push(p),
            Component::CurDir => {}
            _ => return None,
        }
    }
    (out.components().count() > 0 && out.components().count() <= 32).then_some(out)
}

/// Counts the files and bytes written so far against the limits.
struct Budget<'a> {
    limits: &'a RequestLimits,
    files: usize,
    bytes: u64,
}

impl Budget<'_> {
    fn add_file(&mut self) -> Result<(), ApiError> {
        self.files += 1;
        if self.files > self.limits.max_upload_files {
            return Err(too_large(self.limits));
        }
        Ok(())
    }
    fn add_bytes(&mut self, n: u64) -> Result<(), ApiError> {
        self.bytes += n;
        if self.bytes > self.limits.max_upload_bytes {
            return Err(too_large(self.limits));
        }
        Ok(())
    }
}

/// Streams a part into `path`.
async fn save_field(
    field: &mut Field<'_>,
    path: &Path,
    budget: &mut Budget<'_>,
) -> Result<(), ApiError> {
    if let Some(parent) = path.parent() {
        tokio::fs::create_dir_all(parent)
            .await
            .map_err(ApiError::internal)?;
    }
    let mut file = tokio::fs::File::create(path)
        .await
        .map_err(ApiError::internal)?;
    while let Some(chunk) = field.chunk().await.map_err(multipart_error)? {
        budget.add_bytes(chunk.len() as u64)?;
        file.write_all(&chunk).await.map_err(ApiError::internal)?;
    }
    file.flush().await.map_err(ApiError::internal)?;
    Ok(())
}

/// Reads a multipart upload into a fresh folder under `tmp_root`.
pub async fn read_multipart(
    mut mp: Multipart,
    limits: &RequestLimits,
    tmp_root: &Path,
) -> Result<Upload, ApiError> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let root = tmp_root.join(format!(
        "upload-{}-{}",
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    let _ = std::fs::remove_dir_all(&root);
    let files = root.join("files");
    std::fs::create_dir_all(&files).map_err(ApiError::internal)?;
    let root = TempDir(root);
    let archive = root.0.join("archive.bin");
    let mut budget = Budget {
        limits,
        files: 0,
        bytes: 0,
    };
    let (mut job, mut scene, mut has_archive) = (None, None, false);
    // Step 1: the parts.
    while let Some(mut field) = mp.next_field().await.map_err(multipart_error)? {
        let name = match field.name() {
            Some(n) => n.to_string(),
            None => extended_name(field.headers()).unwrap_or_default(),
        };
        match name.as_str() {
            "job" => {
                let bytes = field.bytes().await.map_err(multipart_error)?;
                job = Some(parse_request(&bytes)?);
            }
            "scene" => {
                let file_name = field.file_name().map(str::to_string);
                let bytes = field.bytes().await.map_err(multipart_error)?;
                scene = Some(scene_part(
                    file_name.as_deref(),
                    bytes.to_vec(),
                    &files,
                    &mut budget,
                )?);
            }
            "archive" => {
                if has_archive {
                    return Err(ApiError::bad_request("upload: more than one archive part"));
                }
                has_archive = true;
                save_field(&mut field, &archive, &mut budget).await?;
            }
            "" => return Err(ApiError::bad_request("upload: a part has no name")),
            other => {
                let rel = safe_relative(other).ok_or_else(|| {
                    ApiError::invalid(
                        other,
                        format!("upload: part \"{other}\": an asset's part name must be a relative path inside the scene folder"),
                    )
                })?;
                budget.add_file()?;
                save_field(&mut field, &files.join(rel), &mut budget).await?;
            }
        }
    }
    // Step 2: the archive, unpacked off the async threads.
    let mut base = files.clone();
    if has_archive {
        if scene.is_some() {
            return Err(ApiError::invalid(
                "scene",
                "upload: give the scene inside the archive (scene.json) or as a scene part, not both",
            ));
        }
        let (limits, files2, budget_used) =
            (limits.clone(), files.clone(), (budget.files, budget.bytes));
        let (found, dir) = tokio::task::spawn_blocking(move || {
            let mut b = Budget {
                limits: &limits,
                files: budget_used.0,
                bytes: budget_used.1,
            };
            extract(&archive, &files2, &mut b)?;
            find_scene(&files2)
        })
        .await
        .map_err(ApiError::internal)??;
        scene = Some(found);
        base = dir;
    }
    let scene = scene.ok_or_else(|| {
        ApiError::invalid(
            "scene",
            "scene: missing: an upload needs a scene part or an archive part with scene.json",
        )
    })?;
    // Step 3: a scene of another format becomes candela JSON in the upload's folder.
    let job = job.unwrap_or_default();
    let (scene_json, warnings) = match scene {
        SceneFile::Json(text) => (text, Vec::new()),
        SceneFile::Other(path) => {
            let (lenient, base2, limits) =
                (job.lenient.unwrap_or(false), base.clone(), limits.clone());
            tokio::task::spawn_blocking(move || import_scene(&path, &base2, lenient, limits))
                .await
                .map_err(ApiError::internal)??
        }
    };
    Ok(Upload {
        job,
        scene_json,
        warnings,
        base,
        _root: root,
    })
}

/// The uploaded scene: JSON text, or a file of another format (saved in the upload's folder).
#[derive(Debug)]
enum SceneFile {
    Json(String),
    Other(PathBuf),
}

/// A `scene` part: candela JSON stays text; another format (by the part's file name, else by
/// content) is saved into `files` under its file name, to be imported with the assets.
fn scene_part(
    file_name: Option<&str>,
    bytes: Vec<u8>,
    files: &Path,
    budget: &mut Budget<'_>,
) -> Result<SceneFile, ApiError> {
    use renderer::import::Format;
    let named = file_name.and_then(|n| Path::new(n).file_name().map(PathBuf::from));
    let format = match &named {
        Some(n) => Format::detect(n, &bytes),
        None => Format::sniff(&bytes).unwrap_or(Format::Json),
    };
    if format == Format::Json {
        let text = String::from_utf8(bytes)
            .map_err(|_| ApiError::invalid("scene", "scene: the scene part is not UTF-8 text"))?;
        return Ok(SceneFile::Json(text));
    }
    let ext = match format {
        Format::Mitsuba => "xml",
        Format::Gltf if bytes.starts_with(b"glTF") => "glb",
        Format::Gltf => "gltf",
        Format::Pbrt => "pbrt",
        _ => "scn",
    };
    let name = named
        .filter(|n| renderer::import::Format::from_extension(n) == Some(format))
        .and_then(|n| n.to_str().and_then(safe_relative))
        .unwrap_or_else(|| PathBuf::from(format!("scene.{ext}")));
    budget.add_file()?;
    budget.add_bytes(bytes.len() as u64)?;
    let path = files.join(name);
    std::fs::write(&path, bytes).map_err(ApiError::internal)?;
    Ok(SceneFile::Other(path))
}

/// Imports the scene file `path` into candela JSON whose assets live in `base` (the files it held
/// inline are written there, under `<stem>_assets/`). Bad input is 422 naming the file and line.
fn import_scene(
    path: &Path,
    base: &Path,
    lenient: bool,
    limits: RequestLimits,
) -> Result<(String, Vec<String>), ApiError> {
    let opts = renderer::import::ImportOptions {
        lenient,
        limits: limits.scene_limits(),
        ..Default::default()
    };
    let bad = |e: renderer::scene::SceneError| super::request::scene_error(&e, "scene");
    let imported = renderer::import::import_file(path, &opts).map_err(bad)?;
    let assets = renderer::import::convert::assets_dir_name(path);
    let (text, _) = renderer::import::convert::materialize(&imported, base, &assets)
        .map_err(ApiError::internal)?;
    let warnings = imported.warnings.iter().map(|w| {
        // Name the file as the client knows it: relative to the upload.
        let s = w.to_string();
        let prefix = format!("{}/", base.display());
        s.strip_prefix(&prefix).map(str::to_string).unwrap_or(s)
    });
    Ok((text, warnings.collect()))
}

/// The RFC 5987 form of a part's name (`name*=utf-8''assets%2Fwood.png`), which some clients
/// send for names with `/` and which the multipart parser does not decode.
fn extended_name(headers: &axum::http::HeaderMap) -> Option<String> {
    let cd = headers.get("content-disposition")?.to_str().ok()?;
    let value = cd
        .split(';')
        .map(str::trim)
        .find_map(|p| p.strip_prefix("name*="))?;
    let (charset, rest) = value.split_once('\'')?;
    if !charset.eq_ignore_ascii_case("utf-8") {
        return None;
    }
    let encoded = rest.split_once('\'').map(|(_, v)| v)?.trim_matches('"');
    percent_decode(encoded)
}

/// Decodes `%XX` escapes (UTF-8).
fn percent_decode(s: &str) -> Option<String> {
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = std::str::from_utf8(bytes.get(i + 1..i + 3)?).ok()?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

/// The scene file at the root of `dir` (or inside its only top-level folder): `scene.json`,
/// else `scene.<ext>` of another format, else the only file of another format there.
fn find_scene(dir: &Path) -> Result<(SceneFile, PathBuf), ApiError> {
    let mut base = dir.to_path_buf();
    let mut found = scene_in(dir)?;
    if found.is_none() {
        let entries: Vec<PathBuf> = std::fs::read_dir(dir)
            .map_err(ApiError::internal)?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .collect();
        if let [only] = entries.as_slice() {
            if only.is_dir() {
                found = scene_in(only)?;
                base = only.clone();
            }
        }
    }
    let found = found.ok_or_else(|| {
        ApiError::invalid(
            "archive",
            "archive: no scene at its root (scene.json, or one .xml, .gltf, .glb, .pbrt or .scn file)",
        )
    })?;
    Ok((found, base))
}

/// The scene file directly inside `dir`, if one can be told.
fn scene_in(dir: &Path) -> Result<Option<SceneFile>, ApiError> {
    use renderer::import::Format;
    if let Ok(bytes) = std::fs::read(dir.join("scene.json")) {
        let text = String::from_utf8(bytes)
            .map_err(|_| ApiError::invalid("archive", "archive: scene.json is not UTF-8 text"))?;
        return Ok(Some(SceneFile::Json(text)));
    }
    let mut candidates: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(ApiError::internal)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file())
        .filter(|p| matches!(Format::from_extension(p), Some(f) if f != Format::Json))
        .collect();
    candidates.sort();
    let named_scene: Vec<&PathBuf> = candidates
        .iter()
        .filter(|p| p.file_stem().is_some_and(|s| s == "scene"))
        .collect();
    match (named_scene.as_slice(), candidates.as_slice()) {
        ([one], _) => Ok(Some(SceneFile::Other((*one).clone()))),
        ([], [one]) => Ok(Some(SceneFile::Other(one.clone()))),
        ([], []) => Ok(None),
        _ => Err(ApiError::invalid(
            "archive",
            format!(
                "archive: several scene files at its root ({}); name the scene scene.<ext>",
                candidates
                    .iter()
                    .filter_map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        )),
    }
}

fn bad_archive(msg: impl std::fmt::Display) -> ApiError {
    ApiError::invalid("archive", format!("archive: {msg}"))
}

/// Unpacks a .zip, .tar or .tar.gz (recognised by content) into `dest`.
fn extract(archive: &Path, dest: &Path, budget: &mut Budget<'_>) -> Result<(), ApiError> {
    let mut head = [0u8; 512];
    let n = {
        let mut f = std::fs::File::open(archive).map_err(ApiError::internal)?;
        read_up_to(&mut f, &mut head).map_err(ApiError::internal)?
    };
    let head = &head[..n];
    let file = std::fs::File::open(archive).map_err(ApiError::internal)?;
    if head.starts_with(b"PK\x03\x04") || head.starts_with(b"PK\x05\x06") {
        extract_zip(file, dest, budget)
    } else if head.starts_with(&[0x1f, 0x8b]) {
        extract_tar(flate2::read::GzDecoder::new(file), dest, budget)
    } else if head.len() >= 262 && &head[257..262] == b"ustar" {
        extract_tar(file, dest, budget)
    } else {
        Err(bad_archive("not a .tar, .tar.gz or .zip file"))
    }
}

/// [`extract`] with the server's default limits, for the fuzz test (upload_fuzz.rs).
#[cfg(test)]
pub(crate) fn fuzz_extract(archive: &Path, dest: &Path) -> Result<(), ApiError> {
    let limits = RequestLimits {
        max_upload_bytes: 1 << 20,
        max_upload_files: 64,
        ..Default::default()
    };
    let mut budget = Budget {
        limits: &limits,
        files: 0,
        bytes: 0,
    };
    extract(archive, dest, &mut budget)
}

fn read_up_to(r: &mut impl Read, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut n = 0;
    while n < buf.len() {
        match r.read(&mut buf[n..])? {
            0 => break,
            k => n += k,
        }
    }
    Ok(n)
}

/// Copies one entry to `dest/rel`, counting its bytes (never more than the budget allows).
fn write_entry(
    mut r: impl Read,
    dest: &Path,
    rel: &Path,
    budget: &mut Budget<'_>,
) -> Result<(), ApiError> {
    budget.add_file()?;
    let path = dest.join(rel);
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent).map_err(ApiError::internal)?;
    }
    let mut out = std::fs::File::create(&path).map_err(ApiError::internal)?;
    let left = budget.limits.max_upload_bytes.saturating_sub(budget.bytes);
    let copied = std::io::copy(&mut (&mut r).take(left + 1), &mut out)
        .map_err(|e| bad_archive(format!("{}: {e}", rel.display())))?;
    budget.add_bytes(copied)?;
    out.flush().map_err(ApiError::internal)?;
    Ok(())
}

/// Whether an entry names the archive's root folder itself (`./`).
fn is_top(name: &str) -> bool {
    Path::new(name).components().all(|c| c == Component::CurDir)
}

fn extract_tar(r: impl Read, dest: &Path, budget: &mut Budget<'_>) -> Result<(), ApiError> {
    let mut archive = tar::Archive::new(r);
    for entry in archive.entries().map_err(bad_archive)? {
        let entry = entry.map_err(bad_archive)?;
        let name = entry
            .path()
            .map_err(bad_archive)?
            .to_string_lossy()
            .into_owned();
        let kind = entry.header().entry_type();
        if kind.is_symlink() || kind.is_hard_link() {
            return Err(bad_archive(format!(
                "\"{name}\" is a link; only files and folders are allowed"
            )));
        }
        if !(kind.is_file() || kind.is_dir()) || (kind.is_dir() && is_top(&name)) {
            continue; // pax headers and other metadata; the archive's own "./"
        }
        let rel = safe_relative(&name).ok_or_else(|| {
            bad_archive(format!(
                "\"{name}\" is not a relative path inside the archive"
            ))
        })?;
        if kind.is_dir() {
            std::fs::create_dir_all(dest.join(rel)).map_err(ApiError::internal)?;
        } else {
            write_entry(entry, dest, &rel, budget)?;
        }
    }
    Ok(())
}

fn extract_zip(file: std::fs::File, dest: &Path, budget: &mut Budget<'_>) -> Result<(), ApiError> {
    let mut zip = zip::ZipArchive::new(file).map_err(bad_archive)?;
    if zip.len() > budget.limits.max_upload_files {
        return Err(too_large(budget.limits));
    }
    for i in 0..zip.len() {
        let entry = zip.by_index(i).map_err(bad_archive)?;
        let name = entry.name().to_string();
        if entry.is_dir() && is_top(&name) {
            continue;
        }
        if entry.is_symlink() {
            return Err(bad_archive(format!(
                "\"{name}\" is a link; only files and folders are allowed"
            )));
        }
        let rel = safe_relative(name.trim_end_matches('/'))
            .filter(|_| entry.enclosed_name().is_some())
            .ok_or_else(|| {
                bad_archive(format!(
                    "\"{name}\" is not a relative path inside the archive"
                ))
            })?;
        if entry.is_dir() {
            std::fs::create_dir_all(dest.join(rel)).map_err(ApiError::internal)?;
        } else {
            if entry.size() > budget.limits.max_upload_bytes {
                return Err(too_large(budget.limits));
            }
            write_entry(entry, dest, &rel, budget)?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn extended_names_are_decoded() {
        let mut h = axum::http::HeaderMap::new();
        h.insert(
            "content-disposition",
            "form-data; name*=utf-8''assets%2Fchecker.png; filename=\"checker.png\""
                .parse()
                .unwrap(),
        );
        assert_eq!(extended_name(&h).as_deref(), Some("assets/checker.png"));
        assert_eq!(percent_decode("a%2"), None);
    }

    #[test]
    fn only_plain_relative_paths() {
        assert_eq!(safe_relative("a/b.png"), Some(PathBuf::from("a/b.png")));
        assert_eq!(safe_relative("./a.obj"), Some(PathBuf::from("a.obj")));
        for bad in [
            "",
            "/etc/passwd",
            "../x",
            "a/../../x",
            "a\\..\\x",
            ".",
            "a\0b",
        ] {
            assert_eq!(safe_relative(bad), None, "{bad:?}");
        }
    }

    #[test]
    fn tar_with_escaping_path_is_refused() {
        let dir = std::env::temp_dir().join(format!("candela-upload-test-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(dir.join("out")).unwrap();
        // A tar whose entry name climbs out of the folder (written by hand: tar::Builder refuses).
        let mut header = tar::Header::new_gnu();
        header.as_gnu_mut().unwrap().name[..9].copy_from_slice(b"../evil.t");
        header.set_size(4);
        header.set_entry_type(tar::EntryType::Regular);
        header.set_cksum();
        let mut builder = tar::Builder::new(Vec::new());
        builder.append(&header, &b"evil"[..]).unwrap();
        let bytes = builder.into_inner().unwrap();
        let archive = dir.join("a.tar");
        std::fs::write(&archive, bytes).unwrap();
        let limits = RequestLimits::default();
        let mut budget = Budget {
            limits: &limits,
            files: 0,
            bytes: 0,
        };
        let e = extract(&archive, &dir.join("out"), &mut budget).unwrap_err();
        assert!(e.message().contains("not a relative path"), "{e}");
        assert!(!dir.join("evil.t").exists());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
