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
        && name.split('/').all(|c| {
            !c.is_empty() && c != "." && c != ".." && c.bytes().all(|b| b.is_ascii_alphanumeric() || b"._-".contains(&b))
        })
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
    crate::memory::with_thread_limit(MEMORY_LIMIT, || crate::scene::load_scene(&path, &LoadOptions { params, size: None }))
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
    let (w, h, px) =
        crate::memory::with_thread_limit(MEMORY_LIMIT, || texture::load_bitmap(&path, &Location::new("fuzz.xml", 1), false))?;
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
mod tests {
    use super::*;

    #[test]
    fn bundle_splits_params_and_files() {
        let b = b"@params a=1 b=x=y\n<scene/>\n--8<-- inc/a.xml\n<x/>\n--8<-- ../bad\nzz\n--8<-- m.obj\nv 0 0 0\n";
        let (params, main, files) = split_bundle(b);
        assert_eq!(params, vec![("a".into(), "1".into()), ("b".into(), "x=y".into())]);
        assert_eq!(main, b"<scene/>");
        assert_eq!(files, vec![("inc/a.xml".to_string(), &b"<x/>"[..]), ("m.obj".to_string(), &b"v 0 0 0\n"[..])]);
        let (p, m, f) = split_bundle(b"<scene/>");
        assert!(p.is_empty() && f.is_empty() && m == b"<scene/>");
    }

    #[test]
    fn bundle_with_include_and_mesh_loads() {
        let b = b"@params r=8\n<scene version=\"3.0.0\"><include filename=\"inc.xml\"/>\
<shape type=\"obj\"><string name=\"filename\" value=\"meshes/m.obj\"/></shape></scene>\
\n--8<-- inc.xml\n<scene version=\"3.0.0\"><default name=\"r\" value=\"4\"/><sensor type=\"perspective\">\
<film type=\"hdrfilm\"><integer name=\"width\" value=\"$r\"/><integer name=\"height\" value=\"2\"/></film></sensor></scene>\
\n--8<-- meshes/m.obj\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
        let scene = xml(b).unwrap();
        assert_eq!((scene.camera.width, scene.camera.height), (8, 2));
        assert_eq!(scene.meshes[0].indices, vec![[0, 1, 2]]);
        assert!(xml(b"<scene version=\"3.0.0\"/>").unwrap_err().to_string().contains("no shapes"));
        // A mesh of only zero-area triangles loads empty, as Mitsuba goes on (the scene loader warns);
        // index 0 (OBJ indices start at 1) is still an error.
        assert!(run("obj", b"v 0 0 0\nf 1 1 1\n").is_ok());
        assert!(run("obj", b"v 0 0 0\nf 0 1 1\n").unwrap_err().contains("out of range"));
        assert!(run("png", b"\x89PNG").is_err());
        cleanup();
    }

    /// A bundle whose 7 files each include the next 10 times would parse 10^8 files (a hang, before the
    /// include count was capped): now a clear error naming the include.
    #[test]
    fn include_fan_out_is_refused_quickly() {
        let data = std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/corpus/xml/finding-include-fanout")).unwrap();
        let t0 = std::time::Instant::now();
        let e = xml(&data).unwrap_err().to_string();
        assert!(e.contains("more than 10000 <include>s in one scene") && e.contains(".xml:1:"), "{e}");
        assert!(t0.elapsed().as_secs() < 20, "took {:?}", t0.elapsed());
        cleanup();
    }

    /// A 300-byte EXR whose header asks for a layer of 10^15 bytes made the `exr` crate abort the
    /// process on allocation failure: now an `Io` error naming the file and the layer size.
    #[test]
    fn exr_with_huge_layer_is_refused() {
        let data = std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/corpus/exr/finding-huge-layer")).unwrap();
        let e = image(&data, "exr").unwrap_err().to_string();
        assert!(e.contains("t.exr: EXR layer of 16777217x16777215 pixels is larger than supported"), "{e}");
        cleanup();
    }

    /// JPEG findings: a 556-byte progressive JPEG declaring 2039x65016 pixels decoded to 2.2 GB (5 s), a
    /// 412-byte one declaring 65526x505 took 600 MB (1 s). Under the texture size policy they need more
    /// than the entry points' 512 MiB bound and are refused before decoding, naming the size.
    #[test]
    fn jpegs_declaring_large_images_are_refused_by_the_memory_policy() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/corpus/jpg");
        for (file, want) in [
            // 2039 * 65016 * (3 + 12) + 2048 * 65024 * 8 + 16 MiB
            ("finding-oom-decoded-size", "(JPEG image of 2039x65016 pixels) needs 3.07 GB of host memory but only 536.9 MB"),
            // 65526 * 505 * (3 + 12) + 65536 * 512 * 8 + 16 MiB
            ("finding-slow-progressive", "(JPEG image of 65526x505 pixels) needs 781.6 MB of host memory but only 536.9 MB"),
        ] {
            let data = std::fs::read(root.join(file)).unwrap();
            let e = image(&data, "jpg").unwrap_err();
            let msg = e.to_string();
            assert!(matches!(e, crate::error::Error::OutOfMemory(_)), "{file}: {e:?}");
            assert!(msg.starts_with("fuzz.xml:1: decoding \"") && msg.contains("t.jpg") && msg.contains(want), "{file}: {msg}");
        }
        cleanup();
    }

    /// Replays every committed corpus file (`fuzz/corpus/<target>/*`: seeds, minimised fuzzing finds and
    /// the inputs that once crashed) through the fuzz targets' entry points: an `Err` is fine, a panic is
    /// a failure. Every target must have a corpus, and some of its files must load.
    #[test]
    fn fuzz_corpus_replays_without_panics() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/corpus");
        let mut targets: Vec<PathBuf> = std::fs::read_dir(&root).unwrap().map(|e| e.unwrap().path()).collect();
        targets.sort();
        let names: Vec<String> = targets.iter().map(|t| t.file_name().unwrap().to_string_lossy().into_owned()).collect();
        for want in ["xml", "obj", "ply", "exr", "png", "jpg"] {
            assert!(names.iter().any(|n| n == want), "no corpus for target {want} in {}", root.display());
        }
        // One thread per target (each has its own scratch directory).
        let results: Vec<(usize, usize, Vec<String>)> = std::thread::scope(|scope| {
            let handles: Vec<_> = targets
                .iter()
                .zip(&names)
                .map(|(dir, target)| {
                    scope.spawn(move || {
                        let (mut ok, mut total, mut panics, t0) = (0, 0, Vec::new(), std::time::Instant::now());
                        for file in std::fs::read_dir(dir).unwrap() {
                            let file = file.unwrap().path();
                            let data = std::fs::read(&file).unwrap();
                            total += 1;
                            match std::panic::catch_unwind(|| run(target, &data)) {
                                Ok(Ok(())) => ok += 1,
                                Ok(Err(_)) => {}
                                Err(_) => panics.push(file.display().to_string()),
                            }
                        }
                        cleanup();
                        eprintln!("fuzz corpus {target}: {total} files, {ok} load, {:.2} s", t0.elapsed().as_secs_f64());
                        (ok, total, panics)
                    })
                })
                .collect();
            handles.into_iter().map(|h| h.join().unwrap()).collect()
        });
        let mut panics = Vec::new();
        for (target, (ok, total, p)) in names.iter().zip(results) {
            assert!(ok > 0, "{target}: none of its {total} corpus files loads");
            panics.extend(p);
        }
        assert!(panics.is_empty(), "these corpus inputs panic: {panics:#?}");
    }
}
