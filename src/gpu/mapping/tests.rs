use super::*;
use crate::matrix::mapping::NO_SOURCE;

#[test]
fn wgsl_validates_and_params_match() {
    crate::gpu::shaders::assert_struct_sizes("mapping.wgsl", shaders::MAPPING, &[("MappingParams", 32)]);
    assert_eq!(std::mem::size_of::<MappingParams>(), 32);
}

fn mapping(w: u32, h: u32, seed: u32) -> PixelMapping {
    let m = w * h;
    let source = (0..m).map(|i| if (i * 7 + seed) % 11 == 0 { NO_SOURCE } else { (i * 31 + seed * 17) % m }).collect();
    PixelMapping { width: w, height: h, source }
}

#[test]
fn gpu_gather_equals_cpu_for_maps_and_chains() {
    let ctx = crate::testing::gpu_context();
    let (w, h) = (37, 23);
    let (a, b, c) = (mapping(w, h, 1), mapping(w, h, 2), mapping(w, h, 3));
    let m = (w * h) as usize;
    let images: Vec<f32> = (0..2 * m * 3).map(|v| (v as f32 * 0.37).sin()).collect();
    assert_eq!(apply_chain_gpu(&ctx, &[&a], &images).unwrap(), a.apply(&images, 3).unwrap());
    let chain = PixelMapping::chain(w, h, &[&a, &b, &c]).unwrap();
    assert_eq!(apply_chain_gpu(&ctx, &[&a, &b, &c], &images).unwrap(), chain.apply(&images, 3).unwrap());
    assert_eq!(apply_chain_gpu(&ctx, &[&a, &b], &images).unwrap(), a.then(&b).unwrap().apply(&images, 3).unwrap());
    let bad = PixelMapping { width: w, height: h, source: vec![m as u32 + 5; m] };
    assert!(apply_chain_gpu(&ctx, &[&bad], &images).is_err());
    assert!(apply_chain_gpu(&ctx, &[], &images).is_err());
    assert!(apply_chain_gpu(&ctx, &[&a], &images[..7]).is_err());
}

#[test]
fn weighted_accumulation_on_the_gpu() {
    let ctx = crate::testing::gpu_context();
    let (w, h) = (16, 8);
    let m = (w * h) as usize;
    let a = mapping(w, h, 4);
    let img: Vec<f32> = (0..m * 3).map(|v| v as f32).collect();
    let src = &upload_images(&ctx, &img, m).unwrap()[0];
    let target = &upload_images(&ctx, &vec![1.0; m * 3], m).unwrap()[0];
    let index = upload_mapping(&ctx, &a).unwrap();
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    let pass = MappingPass::shared(&ctx);
    for weight in [[0.5, 2.0, -1.0], [1.0, 1.0, 1.0]] {
        pass.encode(
            &ctx,
            &mut enc,
            &MappingInputs { source: src, mapping: &index, target, num_pixels: m as u32, weight, accumulate: true },
        )
        .unwrap();
    }
    ctx.queue.submit(Some(enc.finish()));
    let got: Vec<[f32; 4]> = ctx.read_buffer(target, 0, m).unwrap();
    let mapped = a.apply(&img, 3).unwrap();
    for i in 0..m {
        for (ch, wsum) in [1.5f32, 3.0, 0.0].iter().enumerate() {
            assert_eq!(got[i][ch], 1.0 + wsum * mapped[i * 3 + ch], "pixel {i} channel {ch}");
        }
    }
}
