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
fn objective_partials_are_one_per_workgroup() {
    // The accumulate dispatches are rows of whole workgroups (`gpu::dispatch::plan_kmeans`), so the
    // partials tile ceil(n / 256) slots; 65,535 x 256 + 1 points take two dispatches, not a 2D grid.
    assert_eq!(num_partials(65_535 * 256 + 1), 65_536);
    assert_eq!(num_partials(1000), 4);
    assert_eq!(num_partials(0), 1);
}
