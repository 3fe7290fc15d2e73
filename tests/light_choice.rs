//! Which light next-event estimation picks: a glossy floor reflecting two small
//! lights of little power, lit by a large, powerful one (the Veach MIS scene in
//! small). Choosing by power alone gave the small lights 0.25 % of the samples each and
//! their highlights were noise; the default mixture of power and uniform choice
//! must be far less noisy, and must converge to the same image as an independent
//! estimator (lights chosen uniformly, spheres sampled by area rather than by cone).

mod common;
use common::*;
use rdr::light::{LightSampler, LightSampling};
use rdr::math::Vec3;
use rdr::metrics::{compare, Image};
use rdr::Profile;

const SCENE: &str = r#"<scene version="3.0.0">
    <integrator type="path"><integer name="max_depth" value="4"/></integrator>
    <sensor type="perspective">
        <float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="0, 2.5, 6" target="0, 0, -1" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="48"/><integer name="height" value="32"/>
            <rfilter type="box"/></film>
    </sensor>
    <shape type="rectangle">
        <transform name="to_world"><scale value="6"/><rotate x="1" angle="-90"/></transform>
        <bsdf type="roughplastic">
            <rgb name="diffuse_reflectance" value="0.07, 0.09, 0.13"/>
            <float name="int_ior" value="2"/><float name="alpha" value="0.05"/>
        </bsdf>
    </shape>
    <shape type="sphere">
        <point name="center" x="-1" y="1" z="-3"/><float name="radius" value="0.05"/>
        <emitter type="area"><rgb name="radiance" value="400, 400, 400"/></emitter>
    </shape>
    <shape type="sphere">
        <point name="center" x="1" y="1" z="-3"/><float name="radius" value="0.2"/>
        <emitter type="area"><rgb name="radiance" value="25, 25, 25"/></emitter>
    </shape>
    <shape type="sphere">
        <point name="center" x="12" y="16" z="8"/><float name="radius" value="1"/>
        <emitter type="area"><rgb name="radiance" value="400, 400, 400"/></emitter>
    </shape>
</scene>"#;

fn scene() -> rdr::Loaded {
    let tmp = temp_dir("rdr-light-choice");
    let path = tmp.path().join("glossy_floor.xml");
    std::fs::write(&path, SCENE).unwrap();
    load_scene(&path, &[], Profile::Physical)
}

/// Mean relative variance at `spp` (of the mean of seeds 1 and 2).
fn noise(loaded: &rdr::Loaded, spp: u32) -> f64 {
    relative_variance_of_mean(&render(loaded, spp, 1), &render(loaded, spp, 2))
}

/// The mean of `k` renders (seeds 100..) and the variance of that mean, per pixel.
fn mean_and_variance(loaded: &rdr::Loaded, spp: u32, k: u32) -> (Image, Image) {
    let images: Vec<Image> = (0..k).map(|s| render(loaded, spp, 100 + s)).collect();
    let n = images[0].pixels.len();
    let (mut mean, mut var) = (vec![Vec3::ZERO; n], vec![Vec3::ZERO; n]);
    for i in 0..n {
        let m = images.iter().map(|im| im.pixels[i]).fold(Vec3::ZERO, |a, b| a + b) / k as f32;
        let v = images
            .iter()
            .map(|im| (im.pixels[i] - m) * (im.pixels[i] - m))
            .fold(Vec3::ZERO, |a, b| a + b);
        (mean[i], var[i]) = (m, v / (k * (k - 1)) as f32);
    }
    let (w, h) = (images[0].width, images[0].height);
    (Image::new(w, h, mean), Image::new(w, h, var))
}

#[test]
fn mixing_uniform_choice_into_power_cuts_the_noise_of_weak_lights_without_bias() {
    let default = scene();
    let mut by_power = scene();
    by_power.scene.light_sampler = LightSampler::with_uniform_share(&by_power.scene.lights, by_power.scene.radius, 0.0);
    let (mixed, power) = (noise(&default, 16), noise(&by_power, 16));
    eprintln!(
        "relative variance at 16 spp: default {mixed:.3e}, lights by power {power:.3e} ({:.1}x)",
        power / mixed
    );
    assert!(
        power > 2.0 * mixed,
        "choosing lights by power alone should be noisier: {power:.3e} vs {mixed:.3e}"
    );

    // converges where lights chosen uniformly and spheres sampled by area do (4x4 blocks)
    let mut uniform = scene();
    uniform.scene.light_sampling = LightSampling::Uniform;
    uniform.scene.light_sampler = LightSampler::new(&uniform.scene.lights, uniform.scene.radius, LightSampling::Uniform);
    let (r, vr) = mean_and_variance(&uniform, 128, 16);
    let block = |i: &Image| i.block_average(4, false);
    let (a, b) = (render(&default, 128, 1), render(&default, 128, 2));
    let c = compare(&block(&a), &block(&b), &block(&r), &vr.block_average(4, true));
    eprintln!("against the uniform estimator: {c:?}");
    assert!(c.rel_mse_corrected.abs() < 5.0 * c.std_error + 2e-4, "biased: {c:?}");
}
