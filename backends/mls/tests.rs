use super::*;
use phyxel::body::shape::Shape;

/// `apply_stiffness` (parallel, gathered per phyxel) gives the bits of a serial
/// scatter over the rows, on a rough vector: the own term sits at its row's place in
/// each sum. Reference: that scatter, written out here.
#[test]
fn stiffness_gather_matches_the_serial_scatter() {
    let mat = Material::default();
    let v = Shape::Sphere { radius: 0.1 }.sample_volume(0.02);
    let p = Phyxels::at_rest(&v.positions, v.cell_volume, mat.density);
    let m = MlsDynamics::new(&p, &mat);
    let n = p.len();
    let x: Vec<Vec3> = (0..n)
        .map(|j| {
            let h = (j as u32).wrapping_mul(2_654_435_761);
            Vec3::new(
                (h & 0xff) as f32,
                (h >> 8 & 0xff) as f32,
                (h >> 16 & 0xff) as f32,
            ) / 127.5
                - Vec3::ONE
        })
        .collect();
    let (mut stress, mut got) = (vec![Mat3::ZERO; n], vec![Vec3::ZERO; n]);
    m.apply_stiffness(&p, &mat, &x, &mut stress, &mut got);
    let st = &m.stencil;
    let mut want = vec![Vec3::ZERO; n];
    for i in 0..n {
        let p_i = stress[i];
        want[i] += p_i * st.d_self[i];
        for k in st.row(i) {
            want[st.neighbours[k] as usize] += p_i * st.d[k];
        }
    }
    assert!(want.iter().any(|w| w.length() > 0.0), "no stiffness");
    for j in 0..n {
        assert_eq!(
            got[j].to_array().map(f32::to_bits),
            want[j].to_array().map(f32::to_bits),
            "phyxel {j}"
        );
    }
}

/// Both passes over buffers of each kind (the fixed view of 65,536 rows, and the
/// checked slice of exactly `padded` rows or of a length no fixed view takes)
/// give the same bits: the masked index reads the row the checked one reads.
/// Reference: the checked slice of `padded` rows, the kernel without fixed views.
#[test]
fn fixed_rows_read_what_checked_rows_read() {
    let mat = Material::default();
    // About 700 phyxels, so the view's rows are mostly past the body's.
    let v = Shape::Sphere { radius: 0.1 }.sample_volume(0.018);
    let mut p = Phyxels::at_rest(&v.positions, v.cell_volume, mat.density);
    for i in 0..p.len() {
        let x = p.rest.get(i);
        p.pos
            .set(i, x + glam::Vec3::new(0.02 * x.y, -0.01 * x.x, 0.03 * x.z));
        p.vel.set(i, glam::Vec3::new(x.z, 0.5 * x.x, -x.y));
    }
    let stencil = phyxel::dynamics::gradient::MlsStencil::build(&p);
    let (in_off, incoming) = incoming_of(&stencil);
    let st = LaneStencil::new(&stencil, &in_off, &incoming);
    let padded = st.padded();
    assert!(
        padded < phyxel::spatial::gather::FIXED_ROWS,
        "{padded} phyxels"
    );
    let law = Law::new(&mat, 1e-4, 1e-4);
    let run = |rows: usize| {
        let mut state = vec![[0.0f32; 8]; rows];
        lanes::pack_state(
            &p.pos,
            &p.rest,
            &p.pos_carry,
            Some(&p.vel),
            &mut state[..padded],
        );
        let mut stress = vec![[0.0f32; 16]; rows];
        let mut grad = vec![Mat3::ZERO; p.len()];
        let input = LaneInputs {
            law,
            state: &state,
            volume: &p.volume,
        };
        let out = LaneOutputs {
            grad: &mut grad,
            plastic: &mut [],
            stress: &mut stress[..padded],
        };
        let strain = lanes::stress_pass(&st, &input, out);
        let mut f = [vec![0.0f32; padded], vec![0.0; padded], vec![0.0; padded]];
        let [fx, fy, fz] = &mut f;
        lanes::force_pass(&st, &stress, fx, fy, fz);
        (strain.to_bits(), grad, f)
    };
    let reference = run(padded);
    assert!(reference.2[0].iter().any(|&v| v != 0.0), "no force");
    for rows in [phyxel::spatial::gather::FIXED_ROWS, padded + 3] {
        let got = run(rows);
        assert_eq!(got.0, reference.0, "{rows} rows: strain");
        assert!(
            got.1
                .iter()
                .zip(&reference.1)
                .all(|(a, b)| a.to_cols_array().map(f32::to_bits)
                    == b.to_cols_array().map(f32::to_bits)),
            "{rows} rows: gradients"
        );
        for (axis, (a, b)) in got.2.iter().zip(&reference.2).enumerate() {
            let same = a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits());
            assert!(same, "{rows} rows: forces along axis {axis}");
        }
    }
}
