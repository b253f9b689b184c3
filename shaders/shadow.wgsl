// Depth-only shadow-map pass (src/gpu/shadow.rs): one draw of all scene triangles per layer; the layer's
// matrix comes through a dynamic uniform offset. Needs common/shadow_layer.wgsl.

@group(0) @binding(0) var<uniform> layer: ShadowLayer;

@vertex
fn vs_main(@location(0) position: vec3<f32>) -> @builtin(position) vec4<f32> {
    return layer.view_proj * vec4<f32>(position, 1.0);
}
