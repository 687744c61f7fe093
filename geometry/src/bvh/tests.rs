//! Unit tests of the occlusion structure.

use super::*;
use glam::dvec3;

fn quad(z: f64, up: bool) -> Vec<[DVec3; 3]> {
    let (a, b, c, d) = (
        dvec3(0.0, 0.0, z),
        dvec3(1.0, 0.0, z),
        dvec3(1.0, 1.0, z),
        dvec3(0.0, 1.0, z),
    );
    if up {
        vec![[a, b, c], [a, c, d]]
    } else {
        vec![[a, c, b], [a, d, c]]
    }
}

#[test]
fn blocks_from_both_sides() {
    let occ = Occluders::from_triangles(&quad(0.5, true));
    assert!(!occ.segment_visible(dvec3(0.5, 0.5, 0.0), dvec3(0.5, 0.5, 1.0)));
    assert!(!occ.segment_visible(dvec3(0.5, 0.5, 1.0), dvec3(0.5, 0.5, 0.0)));
    assert!(occ.segment_visible(dvec3(1.5, 0.5, 0.0), dvec3(1.5, 0.5, 1.0)));
}

#[test]
fn may_block_rules_out_the_two_surfaces_themselves() {
    let mut tris = quad(0.0, true);
    tris.extend(quad(1.0, false));
    let occ = Occluders::from_triangles(&tris);
    let s = [
        dvec3(0.0, 0.0, 0.0),
        dvec3(1.0, 0.0, 0.0),
        dvec3(1.0, 1.0, 0.0),
    ];
    let t = [
        dvec3(0.0, 0.0, 1.0),
        dvec3(1.0, 1.0, 1.0),
        dvec3(1.0, 0.0, 1.0),
    ];
    assert!(!occ.may_block(&s, DVec3::Z, &t, -DVec3::Z));
    // A plate between them is a candidate.
    tris.extend(quad(0.5, true));
    let occ = Occluders::from_triangles(&tris);
    assert!(occ.may_block(&s, DVec3::Z, &t, -DVec3::Z));
}

/// Two patches at right angles, facing each other, and a small triangle in the plane
/// x = y between them: the boxes overlap and the patches lie on both sides of its plane,
/// so only the axis from the centres' segment towards the triangle proves it clear, while
/// it sits near the origin; moved onto the segment, it is a candidate either way.
#[test]
fn may_block_hull_separates_what_boxes_and_planes_cannot() {
    let quad = |c: DVec3, u: DVec3, v: DVec3| [c - u - v, c + u - v, c + u + v, c - u + v];
    let s = quad(
        dvec3(1.0, 0.0, 0.0),
        dvec3(0.0, 0.05, 0.0),
        dvec3(0.0, 0.0, 0.05),
    );
    let t = quad(
        dvec3(0.0, 1.0, 0.0),
        dvec3(0.0, 0.0, 0.05),
        dvec3(0.05, 0.0, 0.0),
    );
    let (ns, nt) = (-DVec3::X, -DVec3::Y);
    let near_origin = [
        dvec3(0.1, 0.1, -0.1),
        dvec3(0.2, 0.2, -0.1),
        dvec3(0.15, 0.15, 0.1),
    ];
    let occ = Occluders::from_triangles(&[near_origin]);
    assert!(
        occ.may_block(&s, ns, &t, nt),
        "boxes and planes leave it open"
    );
    assert!(!occ.may_block_hull(&s, &t), "the axis proves it clear");
    let on_segment = near_origin.map(|p| p + dvec3(0.35, 0.35, 0.0));
    let occ = Occluders::from_triangles(&[on_segment]);
    assert!(occ.may_block(&s, ns, &t, nt));
    assert!(occ.may_block_hull(&s, &t));
    // The patches' own corners give no candidate: nothing else is there.
    let occ = Occluders::from_triangles(&[[s[0], s[1], s[2]], [t[0], t[2], t[1]]]);
    assert!(!occ.may_block_hull(&s, &t));
}

#[test]
fn closest_hit_finds_the_nearest_triangle_and_where() {
    // Two plates at z = 0.5 and z = 1; a ray down from z = 2 meets z = 1 first.
    let mut tris = quad(0.5, true);
    tris.extend(quad(1.0, false));
    let occ = Occluders::from_triangles(&tris);
    let o = dvec3(0.3, 0.6, 2.0);
    let hit = occ
        .closest_hit(o, dvec3(0.0, 0.0, -3.0), 0.0, f64::INFINITY)
        .expect("the ray crosses both plates");
    // f32 traversal: distances good to a few ulps of the scene size.
    assert!((hit.distance - 1.0).abs() < 1e-5, "{hit:?}");
    assert!(hit.triangle >= 2, "{hit:?}");
    let [a, b, c] = tris[hit.triangle as usize];
    let p = a + (b - a) * f64::from(hit.u) + (c - a) * f64::from(hit.v);
    assert!((p - dvec3(0.3, 0.6, 1.0)).length() < 1e-5, "{p}");
    // Nothing within 0.9, and nothing at all beside the plates.
    assert!(occ.closest_hit(o, -DVec3::Z, 0.0, 0.9).is_none());
    assert!(
        occ.closest_hit(dvec3(3.0, 0.0, 2.0), -DVec3::Z, 0.0, 10.0)
            .is_none()
    );
}

/// The 12 triangles of the box `lo`–`hi`, facing out (or in, for a room).
fn boxed(lo: DVec3, hi: DVec3, out: bool) -> Vec<[DVec3; 3]> {
    let mid = (lo + hi) * 0.5;
    let mut tris = Vec::new();
    for axis in 0..3 {
        for side in [lo[axis], hi[axis]] {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            let corner = |a: f64, b: f64| {
                let mut p = DVec3::ZERO;
                p[axis] = side;
                p[u] = a;
                p[v] = b;
                p
            };
            let q = [
                corner(lo[u], lo[v]),
                corner(hi[u], lo[v]),
                corner(hi[u], hi[v]),
                corner(lo[u], hi[v]),
            ];
            let n = (q[1] - q[0]).cross(q[2] - q[0]);
            let outward = n.dot(q[0] - mid) > 0.0;
            let [a, b, c, d] = if outward == out {
                q
            } else {
                [q[3], q[2], q[1], q[0]]
            };
            tris.push([a, b, c]);
            tris.push([a, c, d]);
        }
    }
    tris
}

#[test]
fn burial_and_negative_zero_directions() {
    // A room with a box standing on its floor. obvhs's traversal missed every triangle
    // for a direction with a `-0.0` component: straight up from the floor under the box
    // with (-0, 1, -0) met nothing, with (0, 1, 0) the box's top at 2.2.
    let mut tris = boxed(DVec3::ZERO, dvec3(4.0, 3.0, 5.0), false);
    tris.extend(boxed(dvec3(2.8, 0.0, 0.5), dvec3(3.6, 2.2, 1.2), true));
    let occ = Occluders::from_triangles(&tris);
    let x = dvec3(3.2, 0.0, 1.0);
    for d in [dvec3(0.0, 1.0, 0.0), dvec3(-0.0, 1.0, -0.0)] {
        let hit = occ.closest_hit_from_surface(x, d, 100.0);
        let hit = hit.unwrap_or_else(|| panic!("{d:?} met nothing"));
        assert!((hit.distance - 2.2).abs() < 1e-5, "{d:?}: {hit:?}");
    }
    // Buried: the floor under the box (its inside above), whichever sign its normal's
    // zeros carry; the box's bottom (face to face with the floor). Exposed: the floor
    // beside the box, and the box's top.
    assert!(occ.buried(x, dvec3(0.0, 1.0, 0.0)));
    assert!(occ.buried(x, dvec3(-0.0, 1.0, -0.0)));
    assert!(occ.buried(x, dvec3(0.0, -1.0, 0.0)));
    assert!(!occ.buried(dvec3(2.0, 0.0, 2.5), dvec3(-0.0, 1.0, 0.0)));
    assert!(!occ.buried(dvec3(3.2, 2.2, 1.0), DVec3::Y));
    // Under an open-bottomed shade 2 wide hung 0.5 above the floor (its inside is its
    // back faces): exposed, the grazing rays leave through the gap (they would need more
    // than 87° under a gap of 0.05).
    let mut shade = boxed(dvec3(0.5, 0.5, 2.0), dvec3(2.5, 1.5, 4.0), true);
    shade.retain(|t| t.iter().any(|p| p.y > 0.5));
    let mut tris = boxed(DVec3::ZERO, dvec3(4.0, 3.0, 5.0), false);
    tris.extend(shade);
    let occ = Occluders::from_triangles(&tris);
    assert!(!occ.buried(dvec3(1.5, 0.0, 3.0), DVec3::Y));
    // A two-sided panel (two sheets face to face) in the middle of the room: both sides
    // look out on the room's front faces, neither is buried.
    let mut tris = boxed(DVec3::ZERO, dvec3(4.0, 3.0, 5.0), false);
    let [a, b, c, d] =
        [(1.0, 1.0), (3.0, 1.0), (3.0, 3.0), (1.0, 3.0)].map(|(x, z)| dvec3(x, 1.5, z));
    tris.extend([[a, b, c], [a, c, d], [a, c, b], [a, d, c]]);
    let occ = Occluders::from_triangles(&tris);
    assert!(!occ.buried(dvec3(2.0, 1.5, 2.0), DVec3::Y));
    assert!(!occ.buried(dvec3(2.0, 1.5, 2.0), -DVec3::Y));
}

#[test]
fn a_panels_sheets_out_of_order_show_the_near_front() {
    // A two-sided panel over the floor of a room, modelled as in the conference room: the
    // sheet facing up (+y) lies 1e-5 *below* the sheet facing down, so a ray up from the
    // floor meets the back of the upper-facing sheet first. What it sees is the panel's
    // underside; `reaches` already said so for a ray toward it, the closest hit does not.
    let mut tris = boxed(DVec3::ZERO, dvec3(4.0, 3.0, 5.0), false);
    let sheet =
        |y: f64| [(1.0, 1.0), (3.0, 1.0), (3.0, 3.0), (1.0, 3.0)].map(|(x, z)| dvec3(x, y, z));
    let [a, b, c, d] = sheet(1.5 - 1e-5);
    tris.extend([[a, c, b], [a, d, c]]); // facing +y
    let [a, b, c, d] = sheet(1.5 + 1e-5);
    let under = tris.len() as u32;
    tris.extend([[a, b, c], [a, c, d]]); // facing -y
    let occ = Occluders::from_triangles(&tris);
    let x = dvec3(2.0, 0.0, 2.0);
    let back = occ.closest_hit_from_surface(x, DVec3::Y, 10.0).unwrap();
    assert!(back.triangle < under, "{back:?}");
    let (hit, front) = occ.first_surface_from_surface(x, DVec3::Y, 10.0).unwrap();
    assert!(front && hit.triangle >= under, "{hit:?} {front}");
    assert!((hit.distance - 1.5).abs() < 1e-4, "{hit:?}");
    assert!(occ.reaches(x, dvec3(2.0, 1.5 + 1e-5, 2.0), under));
    // From the camera's side too, and from above: the top sheet's front.
    let (_, front) = occ
        .first_surface(x + DVec3::Y * 0.1, DVec3::Y, 0.0, 10.0)
        .unwrap();
    assert!(front);
    let (hit, front) = occ
        .first_surface_from_surface(dvec3(2.0, 3.0, 2.0), -DVec3::Y, 10.0)
        .unwrap();
    assert!(front && hit.triangle < under, "{hit:?}");
    // A lone back face stays a back face: the room seen from outside.
    let (_, front) = occ
        .first_surface(dvec3(2.0, -1.0, 2.0), DVec3::Y, 0.0, 10.0)
        .unwrap();
    assert!(!front);
}

#[test]
fn parts_in_contact_exchange_nothing() {
    // A block resting on the floor of a room 7 across with a gap of 2e-7 (2.8e-8 of the
    // extent: above the 1e-9 within which a plane holds a point, below the f32 steps of
    // the BVH, as parts modelled against each other come out of f32 files). The floor
    // under it and the block's bottom face each other in contact: buried, and a
    // visibility ray between them finds nothing, as the burial test decides. Before,
    // `reaches` let the pair exchange F ≈ 1 over the contact while burial took that area
    // out of the patches: rows over the exposed part up to 2.3 in the conference room.
    let gap = 2e-7;
    let mut tris = boxed(DVec3::ZERO, dvec3(4.0, 3.0, 5.0), false);
    let bottom = tris.len() as u32;
    tris.extend(boxed(dvec3(1.0, gap, 1.0), dvec3(2.0, 1.0, 2.0), true));
    let occ = Occluders::from_triangles(&tris);
    let (x, y) = (dvec3(1.3, 0.0, 1.6), dvec3(1.3, gap, 1.6));
    let (on_floor, on_bottom) = (dvec3(1.35, 0.0, 1.62), dvec3(1.35, gap, 1.62));
    let holding = |range: core::ops::Range<u32>, p: DVec3| {
        range
            .clone()
            .find(|&t| {
                let c = tris[t as usize];
                c.iter().all(|q| q.y == p.y) && inside_by(&c, p, 0.0)
            })
            .unwrap()
    };
    let floor = holding(0..bottom, on_floor);
    let bottom = holding(bottom..tris.len() as u32, on_bottom);
    assert!(!occ.reaches(x, on_bottom, bottom));
    assert!(!occ.reaches(y, on_floor, floor));
    assert!(occ.buried(x, DVec3::Y));
    assert!(occ.buried(y, -DVec3::Y));
    let (_, front) = occ.first_surface_from_surface(x, DVec3::Y, 10.0).unwrap();
    assert!(!front);
    // Beside the block the floor is exposed and sees the block's side.
    assert!(!occ.buried(dvec3(2.5, 0.0, 1.5), DVec3::Y));
    // Raised by 1e-3 (1.4e-4 of the extent, far above f32 rounding) it is a real gap:
    // the floor under the block sees its bottom.
    let mut tris = boxed(DVec3::ZERO, dvec3(4.0, 3.0, 5.0), false);
    tris.extend(boxed(dvec3(1.0, 1e-3, 1.0), dvec3(2.0, 1.0, 2.0), true));
    let occ = Occluders::from_triangles(&tris);
    let (hit, front) = occ.first_surface_from_surface(x, DVec3::Y, 10.0).unwrap();
    assert!(front && (hit.distance - 1e-3).abs() < 1e-5, "{hit:?}");
    assert!(!occ.buried(x, DVec3::Y));
}

/// A two-sided sheet in the open (its triangles and their twins, the same corners wound the
/// other way) is exposed on both sides; a plate lying face to face on it without being its
/// twin still buries it (a block's bottom on a floor).
#[test]
fn a_two_sided_sheet_in_the_open_is_exposed_on_both_sides() {
    let mut tris = quad(0.0, true);
    tris.extend(quad(0.0, false));
    let occ = Occluders::from_triangles(&tris);
    let x = dvec3(0.3, 0.4, 0.0);
    assert!(!occ.buried(x, DVec3::Z), "the front of the sheet");
    assert!(!occ.buried(x, -DVec3::Z), "its back");
    // The same sheet against a smaller plate facing it (not a twin): the sheet's front under
    // the plate is buried, as a floor under a block.
    let mut tris = quad(0.0, true);
    let (a, b, c, d) = (
        dvec3(0.2, 0.2, 0.0),
        dvec3(0.8, 0.2, 0.0),
        dvec3(0.8, 0.8, 0.0),
        dvec3(0.2, 0.8, 0.0),
    );
    tris.extend([[a, c, b], [a, d, c]]);
    let occ = Occluders::from_triangles(&tris);
    assert!(occ.buried(dvec3(0.5, 0.5, 0.0), DVec3::Z));
}

/// Steps modelled as boxes from the ground up to their treads, each higher one standing inside
/// the one below, all with their backs against a plinth (`scripts/architecture.py`). The faces
/// inside another box (a lower step's top under the step above, a higher step's front inside
/// the step below, the backs against the plinth, the bottoms on the ground) are buried; the
/// treads, the risers above the step below and the sides are exposed. From inside, rays meet
/// the inner boxes' front faces and the backs tied with the plinth's and the ground's fronts:
/// before those counted as surface seen, three fifths of each step's area stayed in the matrix
/// and its patches gathered light inside the boxes (`docs/decisions/shaded-steps.md`).
#[test]
fn faces_inside_nested_boxes_are_buried() {
    let mut tris = quad_y(-20.0, 20.0, 0.0);
    tris.extend(boxed(dvec3(-6.0, 0.0, 0.0), dvec3(6.0, 0.6, 8.0), true)); // the plinth
    let (rise, tread) = (0.15, 0.3);
    for k in 0..4 {
        let top = rise * f64::from(k + 1);
        let run = tread * f64::from(4 - k);
        tris.extend(boxed(dvec3(-1.5, 0.0, -run), dvec3(1.5, top, 0.0), true));
    }
    let occ = Occluders::from_triangles(&tris);
    for k in 0..4 {
        let top = rise * f64::from(k + 1);
        let front = -tread * f64::from(4 - k);
        let exposed = [
            ("tread", dvec3(0.3, top, front + 0.5 * tread), DVec3::Y),
            ("riser", dvec3(0.3, top - 0.5 * rise, front), -DVec3::Z),
            ("side", dvec3(1.5, top - 0.5 * rise, front + 0.1), DVec3::X),
            (
                "side",
                dvec3(-1.5, top - 0.5 * rise, front + 0.1),
                -DVec3::X,
            ),
        ];
        for (what, x, n) in exposed {
            assert!(!occ.buried(x, n), "step {k}'s {what} at {x} is exposed");
        }
        let mut buried = vec![
            ("back", dvec3(0.3, 0.5 * top, 0.0), DVec3::Z),
            ("bottom", dvec3(0.3, 0.0, 0.5 * front), -DVec3::Y),
        ];
        if k < 3 {
            buried.push((
                "top under the next step",
                dvec3(-0.37, top, front + 1.53 * tread),
                DVec3::Y,
            ));
        }
        if k > 0 {
            let low = 0.5 * rise * f64::from(k);
            buried.push((
                "riser inside the step below",
                dvec3(-0.37, low, front),
                -DVec3::Z,
            ));
        }
        for (what, x, n) in buried {
            assert!(occ.buried(x, n), "step {k}'s {what} at {x} is buried");
        }
    }
    // The ground under the lowest step, which sees the next step's riser inside it.
    assert!(occ.buried(dvec3(0.2, 0.0, -1.05), DVec3::Y));
    assert!(!occ.buried(dvec3(0.2, 0.0, -1.5), DVec3::Y));
}

/// A square of the plane `y` from `lo` to `hi` in x and z, facing +y.
fn quad_y(lo: f64, hi: f64, y: f64) -> Vec<[DVec3; 3]> {
    let [a, b, c, d] = [(lo, lo), (lo, hi), (hi, hi), (hi, lo)].map(|(x, z)| dvec3(x, y, z));
    vec![[a, b, c], [a, c, d]]
}

/// A floor quad at z = 0 facing up, a sheet of coverage `c` facing up at z = 0.5, and (with
/// `second`) another of coverage `c` at z = 0.75.
fn covered_sheets(c: f32, second: bool) -> Occluders {
    let mut tris = quad(0.0, true);
    tris.extend(quad(0.5, true));
    let mut coverage = vec![1.0, 1.0, c, c];
    if second {
        tris.extend(quad(0.75, true));
        coverage.extend([c, c]);
    }
    Occluders::from_triangles(&tris).with_coverage(coverage)
}

/// Points on a 64 × 64 grid inside the unit square at height `z`.
fn grid(z: f64) -> impl Iterator<Item = DVec3> {
    (0..64 * 64).map(move |k| {
        let (i, j) = (k % 64, k / 64);
        dvec3((i as f64 + 0.5) / 64.0, (j as f64 + 0.5) / 64.0, z)
    })
}

#[test]
fn partial_coverage_lets_its_share_of_rays_through() {
    // 4096 rays of a hash: the fraction through has a standard deviation of
    // sqrt(0.3·0.7/4096) = 0.007; 0.03 is four of them.
    let occ = covered_sheets(0.3, false);
    let through = grid(0.01)
        .filter(|&p| occ.segment_visible(p, p + dvec3(0.0, 0.0, 1.0)))
        .count() as f64
        / 4096.0;
    assert!((through - 0.7).abs() < 0.03, "{through}");
    // Closest hits from below meet the sheet with probability 0.3.
    let met = grid(0.01)
        .filter(|&p| {
            occ.closest_hit(p, dvec3(0.0, 0.0, 1.0), 0.0, 10.0)
                .is_some_and(|h| h.triangle >= 2)
        })
        .count() as f64
        / 4096.0;
    assert!((met - 0.3).abs() < 0.03, "{met}");
    // The same ray asks the same question every time.
    let p = dvec3(0.3, 0.6, 0.01);
    let d = dvec3(0.0, 0.0, 1.0);
    assert_eq!(
        occ.closest_hit(p, d, 0.0, 10.0),
        occ.closest_hit(p, d, 0.0, 10.0)
    );
}

#[test]
fn transmittance_multiplies_over_the_sheets_crossed() {
    // Exact: (1 − 0.4) per sheet, in f64 from an f32 coverage (0.4f32 = 0.4000000059...).
    // The points lie off the quads' diagonals: a ray through an edge meets both triangles
    // (`EDGE_SLACK`) and would count a sheet twice.
    let occ = covered_sheets(0.4, true);
    let up = |p: DVec3| occ.segment_transmittance(p, p + dvec3(0.0, 0.0, 2.0));
    assert!((up(dvec3(0.3, 0.6, 0.01)) - 0.36).abs() < 1e-6);
    assert!((up(dvec3(0.3, 0.6, 0.6)) - 0.6).abs() < 1e-6);
    assert_eq!(up(dvec3(0.3, 0.6, 0.8)), 1.0);
    // An opaque triangle across it: nothing.
    let opaque =
        |p: DVec3| occ.segment_transmittance(p + dvec3(0.0, 0.0, 2.0), p - dvec3(0.0, 0.0, 0.5));
    assert_eq!(opaque(dvec3(0.3, 0.3, 0.0)), 0.0);
    // Without coverage every segment is all or nothing.
    let plain = Occluders::from_triangles(&quad(0.5, true));
    assert_eq!(
        plain.segment_transmittance(dvec3(0.5, 0.5, 0.0), dvec3(0.5, 0.5, 1.0)),
        0.0
    );
    assert_eq!(
        plain.segment_transmittance(dvec3(1.5, 0.5, 0.0), dvec3(1.5, 0.5, 1.0)),
        1.0
    );
}

#[test]
fn a_target_of_partial_coverage_is_reached_a_sheet_on_the_way_passes_its_share() {
    // From the floor to the lower sheet (triangles 2 and 3, coverage 0.25): every ray
    // reaches it (the form factors scale by the target's coverage themselves); to the upper
    // one (4 and 5) through the lower: three quarters (four-sigma bound as above,
    // sqrt(0.25·0.75/4096) = 0.0068).
    let occ = covered_sheets(0.25, true);
    let reached = |z: f64, first: u32| {
        grid(0.0)
            .filter(|&p| {
                let to = dvec3(1.0 - p.x, 1.0 - p.y, z);
                let t = if to.x >= to.y { first } else { first + 1 };
                occ.reaches(p, to, t)
            })
            .count() as f64
            / 4096.0
    };
    assert_eq!(reached(0.5, 2), 1.0);
    let through = reached(0.75, 4);
    assert!((through - 0.75).abs() < 0.03, "{through}");
    // A sheet with holes buries nothing: the floor under a sheet of coverage 0.999 facing
    // up (the floor's rays meet its back, as the inside of a slab) is as open as under none.
    let mut tris = quad(0.0, true);
    tris.extend(quad(0.001, true));
    let solid = Occluders::from_triangles(&tris);
    let holed = Occluders::from_triangles(&tris).with_coverage(vec![1.0, 1.0, 0.999, 0.999]);
    let x = dvec3(0.5, 0.5, 0.0);
    assert!(solid.buried(x, dvec3(0.0, 0.0, 1.0)));
    assert!(!holed.buried(x, dvec3(0.0, 0.0, 1.0)));
}
