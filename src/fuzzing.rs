//! Byte-slice entry points for the fuzz targets (`fuzz/`, `make fuzz`) and the corpus replay test
//! (`fuzzing::tests::fuzz_corpus_replays_without_panics`). Not part of the public API.
//!
//! The readers take file paths, so each entry point writes its input to a private temporary directory
//! (one per thread; emptied before each scene bundle, single files are overwritten) and calls the public loader on it: the fuzzed code is
//! exactly what users run, file access included.
//!
//! - [`xml`]: a scene bundle. The main `scene.xml`, optionally preceded by a line `@params k=v k2=v2`
//!   (passed as `LoadOptions::params`), then any number of extra files, each introduced by a line
//!   `--8<-- NAME` (see [`FILE_MARK`]); NAME is a relative path (`a.xml`, `meshes/m.obj`, `t.png`) that the
//!   scene can `<include>` or name as a mesh or texture. Invalid names are skipped.
//! - [`obj`], [`ply`]: `load_obj` / `load_ply`, then `mesh::finalize` (as a shape with identity
//!   `to_world`, smooth and flat shading).
//! - [`image`]: `texture::load_bitmap` on a file with the given extension (`png`, `jpg`, `exr`, ...): the
//!   path textures and environment maps take.
//!
//! Every entry point runs its loader with the host-memory checks bounded by [`MEMORY_LIMIT`] on its thread
//! (`memory::with_thread_limit`, as if `MANYLIGHTS_MEMORY_LIMIT` were that): an input declaring more (e.g. an
//! image that decodes to gigabytes) must be refused by the memory policy, so a process growing past the
//! fuzzer's `-rss_limit_mb=2048` is a finding.
use crate::error::{Location, Result};
use crate::scene::{mesh, texture, LoadOptions, Scene};
use glam::{Mat4, Vec3};
use std::path::{Path, PathBuf};

/// The line that starts an extra file in an [`xml`] bundle: `--8<-- NAME`.
pub const FILE_MARK: &[u8] = b"\n--8<-- ";
/// The line prefix giving `LoadOptions::params` in an [`xml`] bundle.
pub const PARAMS_MARK: &[u8] = b"@params ";
/// Host memory the entry points' loaders may use (512 MiB; `crate::memory::with_thread_limit`).
pub const MEMORY_LIMIT: u64 = 512 << 20;
/// At most this many extra files are written per bundle (the rest are ignored).
const MAX_FILES: usize = 8;

/// This thread's scratch directory (created on first use); `clean` empties it first.
fn scratch(clean: bool) -> PathBuf {
    use std::sync::atomic::{AtomicUsize, Ordering};
    static NEXT: AtomicUsize = AtomicUsize::new(0);
    thread_local! {
        static DIR: PathBuf = std::env::temp_dir()
            .join(format!("manylights-fuzz-{}-{}", std::process::id(), NEXT.fetch_add(1, Ordering::Relaxed)));
    }
    let dir = DIR.with(|d| d.clone());
    if clean {
        let _ = std::fs::remove_dir_all(&dir);
    }
    std::fs::create_dir_all(&dir).expect("cannot create the fuzzing scratch directory");
    dir
}

/// Removes this thread's scratch directory (for tests that replay many inputs).
pub fn cleanup() {
    let _ = std::fs::remove_dir_all(scratch(false));
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    if let Some(parent) = p.parent() {
        std::fs::create_dir_all(parent).expect("cannot create a scratch subdirectory");
    }
    std::fs::write(&p, bytes).expect("cannot write a scratch file");
    p
}

/// A bundle file name is usable when it is a short relative path of plain components.
fn valid_name(name: &str) -> bool {
    !name.is_empty()
        && name.len() <= 64
        && name != "scene.xml"
        && name
            .split('/')
            .all(|c| !c.is_empty() && c != "." && c != ".." && c.bytes().all(|b| b.is_ascii_alphanumeric() || b"._-".contains(&b)))
}

fn find(hay: &[u8], needle: &[u8]) -> Option<usize> {
    hay.windows(needle.len()).position(|w| w == needle)
}

/// Splits an [`xml`] bundle into (params, main scene, [(name, bytes)]).
pub fn split_bundle(data: &[u8]) -> (Vec<(String, String)>, &[u8], Vec<(String, &[u8])>) {
    let mut params = Vec::new();
    let mut rest = data;
    if let Some(after) = rest.strip_prefix(PARAMS_MARK) {
        let end = after.iter().position(|&b| b == b'\n').unwrap_or(after.len());
        for kv in String::from_utf8_lossy(&after[..end]).split_ascii_whitespace() {
            if let Some((k, v)) = kv.split_once('=') {
                params.push((k.to_string(), v.to_string()));
            }
        }
        rest = after.get(end + 1..).unwrap_or(&[]);
    }
    let (main, mut tail) = match find(rest, FILE_MARK) {
        Some(i) => (&rest[..i], Some(&rest[i + FILE_MARK.len()..])),
        None => (rest, None),
    };
    let mut files = Vec::new();
    while let Some(t) = tail {
        let name_end = t.iter().position(|&b| b == b'\n').unwrap_or(t.len());
        let name = String::from_utf8_lossy(&t[..name_end]).trim().to_string();
        let body = t.get(name_end + 1..).unwrap_or(&[]);
        let (content, next) = match find(body, FILE_MARK) {
            Some(i) => (&body[..i], Some(&body[i + FILE_MARK.len()..])),
            None => (body, None),
        };
        if files.len() < MAX_FILES && valid_name(&name) {
            files.push((name, content));
        }
        tail = next;
    }
    (params, main, files)
}

/// Loads a scene bundle (see the module doc) with `load_scene`.
pub fn xml(data: &[u8]) -> Result<Scene> {
    let (params, main, files) = split_bundle(data);
    let dir = scratch(true);
    for (name, bytes) in &files {
        // A name that clashes with an earlier one ("a" then "a/b") is skipped, like an invalid name.
        let p = dir.join(name);
        let _ = p.parent().map(std::fs::create_dir_all).unwrap_or(Ok(())).and_then(|_| std::fs::write(&p, bytes));
    }
    let path = write(&dir, "scene.xml", main);
    crate::memory::with_thread_limit(MEMORY_LIMIT, || {
        crate::scene::load_scene(&path, &LoadOptions { params, size: None, ..Default::default() })
    })
}

fn finalize_both(data: mesh::MeshData, path: &Path) -> Result<mesh::WorldMesh> {
    let loc = Location::new(path, 0);
    let flat = mesh::finalize(data.clone(), Mat4::IDENTITY, true, true, &loc);
    let smooth = mesh::finalize(data, Mat4::IDENTITY, false, false, &loc)?;
    flat.map(|_| smooth)
}

/// Reads bytes as an OBJ file (`load_obj`), then finalizes the mesh.
pub fn obj(data: &[u8]) -> Result<mesh::WorldMesh> {
    let path = write(&scratch(false), "m.obj", data);
    crate::memory::with_thread_limit(MEMORY_LIMIT, || finalize_both(mesh::load_obj(&path, &Location::new("fuzz.xml", 1))?, &path))
}

/// Reads bytes as a PLY file (`load_ply`), then finalizes the mesh.
pub fn ply(data: &[u8]) -> Result<mesh::WorldMesh> {
    let path = write(&scratch(false), "m.ply", data);
    crate::memory::with_thread_limit(MEMORY_LIMIT, || finalize_both(mesh::load_ply(&path, &Location::new("fuzz.xml", 1))?, &path))
}

/// Reads bytes as a bitmap file with extension `ext` (`texture::load_bitmap`, sRGB decoding on).
pub fn image(data: &[u8], ext: &str) -> Result<(u32, u32, Vec<Vec3>)> {
    let path = write(&scratch(false), &format!("t.{ext}"), data);
    let (w, h, px) = crate::memory::with_thread_limit(MEMORY_LIMIT, || texture::load_bitmap(&path, &Location::new("fuzz.xml", 1), false))?;
    assert_eq!(px.len(), w as usize * h as usize, "load_bitmap returned {} texels for {w}x{h}", px.len());
    Ok((w, h, px))
}

/// The entry point for a corpus directory name: `xml`, `obj`, `ply`, else an image extension.
pub fn run(target: &str, data: &[u8]) -> std::result::Result<(), String> {
    let r = match target {
        "xml" => xml(data).map(|_| ()),
        "obj" => obj(data).map(|_| ()),
        "ply" => ply(data).map(|_| ()),
        ext => image(data, ext).map(|_| ()),
    };
    r.map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests;
