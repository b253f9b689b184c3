//! PyO3 bindings (feature `python`): thin wrappers that check arguments, release the GIL and call core.
use pyo3::prelude::*;

pub mod animation;
pub mod baselines;
pub mod bsdf;
pub mod cluster;
pub mod clustered_visibility;
pub mod errors;
pub mod gather;
pub mod image;
pub mod kmeans;
pub mod lightcuts;
pub mod lights;
pub mod lightset;
pub mod matrix;
pub mod probes;
pub mod relight;
pub mod scene;
pub mod signals;
pub mod tensor;
pub mod transfer;
pub mod transfer_store;
pub mod util;
pub mod variance;

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    errors::register(m)?;
    crate::threads::start_global_pool()?;
    signals::install();
    crate::gpu::wsi_env::quiet_device_select();
    scene::register(m)?;
    matrix::register(m)?;
    baselines::register(m)?;
    lightcuts::register(m)?;
    image::register(m)?;
    bsdf::register(m)?;
    lights::register(m)?;
    cluster::register(m)?;
    clustered_visibility::register(m)?;
    kmeans::register(m)?;
    animation::register(m)?;
    tensor::register(m)?;
    gather::register(m)?;
    relight::register(m)?;
    transfer::register(m)?;
    transfer_store::register(m)?;
    variance::register(m)?;
    probes::register(m)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
