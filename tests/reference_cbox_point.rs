//! The default (physically based) `intersection_test` converges to Mitsuba 3's
//! render of the same scene (`shared/refs/cbox_point_hq.exr`), and renderers with
//! the classic mistakes do not.

mod common;
use common::*;
use rdr::metrics::{compare, Comparison};
use rdr::Profile;

const SPP: u32 = 8;
const BLOCK: usize = 2;

fn check(name: &str, x1: &rdr::metrics::Image, x2: &rdr::metrics::Image, r: &rdr::metrics::Image, vr: &rdr::metrics::Image) -> Comparison {
    let c = compare(
        &x1.block_average(BLOCK, false),
        &x2.block_average(BLOCK, false),
        &r.block_average(BLOCK, false),
        &vr.block_average(BLOCK, true),
    );
    eprintln!(
        "{name:>22}: relMSE corrected {:+.3e} ± {:.1e} (raw {:.3e}, noise {:.3e}, mean z² {:.2})",
        c.rel_mse_corrected, c.std_error, c.rel_mse_raw, c.rel_mse_noise, c.mean_z2
    );
    c
}

#[test]
fn cbox_point_converges_to_mitsuba_and_wrong_shading_does_not() {
    let Some(shared) = shared() else { return };
    let refs = shared.join("refs");
    let r = read(&refs.join("cbox_point_hq.exr"));
    let vr = read(&refs.join("cbox_point_hq.var.exr"));
    let scene = load_scene(&refs.join("scenes/cbox_point.json"), &[], Profile::Physical);
    let x1 = render(&scene, SPP, 1);
    let x2 = render(&scene, SPP, 2);

    let good = check("rdr", &x1, &x2, &r, &vr);
    // |bias| below 0.1 % relative MSE, and consistent with zero within the noise
    assert!(good.rel_mse_corrected.abs() < 1e-3, "{good:?}");
    assert!(good.rel_mse_corrected.abs() < 5.0 * good.std_error + 1e-4, "{good:?}");

    // the image means agree too (stats.json: the reference's own mean is exact to ~1e-4)
    let (m, mr) = ((x1.mean() + x2.mean()) * 0.5, r.mean());
    assert!(((m - mr) / mr).abs().max_element() < 2e-3, "mean {m} vs reference {mr}");

    // A renderer that forgets the 1/π of the Lambertian BRDF.
    let no_inv_pi = check(
        "without 1/π",
        &scaled(&x1, std::f32::consts::PI),
        &scaled(&x2, std::f32::consts::PI),
        &r,
        &vr,
    );
    assert!(
        no_inv_pi.rel_mse_corrected > 100.0 * good.rel_mse_corrected.abs().max(1e-4),
        "{no_inv_pi:?}"
    );
    // A renderer that divides by 4π twice / forgets the flux→intensity conversion.
    let no_4pi = check(
        "intensity = flux",
        &scaled(&x1, 4.0 * std::f32::consts::PI),
        &scaled(&x2, 4.0 * std::f32::consts::PI),
        &r,
        &vr,
    );
    assert!(
        no_4pi.rel_mse_corrected > 100.0 * good.rel_mse_corrected.abs().max(1e-4),
        "{no_4pi:?}"
    );
    // RDR171's own shading multiplies by d² instead of dividing (the --compat profile does exactly that).
    let compat_scene = load_scene(&refs.join("scenes/cbox_point.json"), &[], Profile::Rdr171);
    let d2 = render(&compat_scene, SPP, 0);
    let wrong = check("d² instead of 1/d²", &d2, &d2, &r, &vr);
    assert!(
        wrong.rel_mse_corrected > 100.0 * good.rel_mse_corrected.abs().max(1e-4),
        "{wrong:?}"
    );
    // Even a 2 % brightness error is caught.
    let off = check("2 % too bright", &scaled(&x1, 1.02), &scaled(&x2, 1.02), &r, &vr);
    assert!(
        off.rel_mse_corrected > 5.0 * off.std_error && off.rel_mse_corrected > 2.0 * good.rel_mse_corrected.abs(),
        "{off:?}"
    );
}
