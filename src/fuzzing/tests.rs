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
    for want in ["xml", "obj", "ply", "exr", "png", "jpg", "hdr", "pfm", "bmp", "ppm", "tga"] {
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

/// The bump / normal map seed (`fuzz/seeds.py`, `perturb.xml`) loads: the wrapper used by reference, the unused one
/// dropped, the normalmap inside a twosided.
#[test]
fn perturbation_seed_loads() {
    let data =
        std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/corpus/xml/ae38fe46a94893577bd94d381a49cdab6c0c9b41")).unwrap();
    let scene = xml(&data).unwrap();
    use crate::scene::Bsdf;
    assert!(scene.bsdfs.iter().filter(|b| matches!(b, Bsdf::BumpMap { .. })).count() == 1);
    assert!(scene.bsdfs.iter().any(|b| matches!(b, Bsdf::NormalMap { .. })));
    cleanup();
}
