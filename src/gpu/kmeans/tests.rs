use super::*;

#[test]
fn wgsl_validates_and_params_match() {
    let module = crate::gpu::shaders::assert_struct_sizes("kmeans.wgsl", shaders::KMEANS, &[("Params", 112), ("Point", 32)]);
    assert_eq!(std::mem::size_of::<GpuKMeansParams>(), 112);
    assert_eq!(std::mem::size_of::<GpuPoint>(), 32);
    let entries: Vec<&str> = module.entry_points.iter().map(|e| e.name.as_str()).collect();
    for name in ENTRY_POINTS {
        assert!(entries.contains(&name), "missing entry point {name}");
    }
}

#[test]
fn grid_sizes_follow_the_target_and_flat_boxes() {
    let g = Grid::new([0.0; 3], [1.0, 1.0, 1.0], 1000);
    assert!(g.num_cells() <= 1000 && g.num_cells() >= 700, "{g:?}");
    assert!(g.dims.iter().all(|&d| d == g.dims[0]));
    // A flat (planar) box: one cell across the flat axis, about the target over the plane.
    let g = Grid::new([0.0; 3], [2.0, 1.0, 0.0], 200);
    assert_eq!(g.dims[2], 1);
    assert!(g.num_cells() <= 200 && g.num_cells() >= 140, "{g:?}");
    assert!(g.dims[0] as f32 * g.h >= 2.0 && g.dims[1] as f32 * g.h >= 1.0);
    assert_eq!(Grid::new([1.0; 3], [1.0; 3], 50).dims, [1, 1, 1]);
    assert!(Grid::new([0.0; 3], [1.0; 3], 1 << 30).num_cells() <= MAX_GRID_CELLS);
}

#[test]
fn objective_partials_cover_every_workgroup_of_the_dispatch() {
    // Beyond 65,535 x 256 points the 2D grid holds more workgroups than the points need; each writes a
    // partial, so the buffer is sized for the grid (the old 1D count wrote past its end).
    let n = 65_535 * 256 + 1;
    let (gx, gy) = dispatch_grid(n, 65_535);
    assert_eq!((gx, gy), (65_535, 2));
    assert!(gx as usize * gy as usize > n.div_ceil(256));
    assert_eq!(dispatch_grid(1000, 65_535), (4, 1));
    assert_eq!(dispatch_grid(0, 65_535), (1, 1));
}
