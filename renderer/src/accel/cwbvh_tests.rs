//! Host tests of the compressed wide BVH (renderer/src/accel/cwbvh.rs): every primitive in
//! exactly one leaf whose decoded box contains it, chains far deeper than the stack bounded
//! within it (and a bounded binary tree converted no deeper), `depth_of` rejecting what is not a
//! tree, the empty scene, copies of one box grouped (`distinct_boxes`) and expanded in place as
//! the top-down copy would (`expanding_copies_in_place_matches_the_top_down_copy`), and the
//! parallel conversion giving obvhs's serial tree bit for bit (`parallel_conversion_is_obvhs_s`),
//! and which trees are sparse (`few_primitives_make_a_sparse_tree`).
use obvhs::BvhBuildParams;

use super::*;
use crate::accel::tests::random_boxes;

fn unit_boxes(n: usize) -> Vec<PrimBounds> {
    (0..n)
        .map(|i| {
            let (x, y) = ((i % 37) as f32, (i / 37) as f32 * 0.7);
            PrimBounds {
                min: [x, y, 0.0],
                max: [x + 0.5, y + 1.0, 1.0],
            }
        })
        .collect()
}

/// Boxes nested about a common corner, each 0.8 times the last: PLOC chains them.
fn nested_boxes(n: usize) -> Vec<PrimBounds> {
    (0..n)
        .map(|i| {
            let s = 0.8f32.powi(i as i32 % 300) * (1.0 + i as f32 * 1e-4);
            PrimBounds {
                min: [0.0, 0.0, 0.0],
                max: [s, s, s * 1e-3],
            }
        })
        .collect()
}

/// Child c's box of node n as the shader decodes it (f32, `p + e·q`).
fn child_box(n: &GpuCwbvhNode, c: usize) -> ([f32; 3], [f32; 3]) {
    let e = |a: usize| f32::from_bits((n.e_imask[a] as u32) << 23);
    let lo = [0, 1, 2].map(|a| n.p[a] + e(a) * n.q[2 * a][c] as f32);
    let hi = [0, 1, 2].map(|a| n.p[a] + e(a) * n.q[2 * a + 1][c] as f32);
    (lo, hi)
}

/// Every primitive is in exactly one leaf, whose decoded box contains it (within the
/// quantisation obvhs rounds with, a few ulps), every inner child's box contains the boxes
/// of the node it points to, and the depth is within the stack.
fn check(prims: &[PrimBounds], b: &Built) {
    let mut seen = vec![0u32; prims.len()];
    assert!(leaves_in_range(&b.nodes, b.order.len()));
    assert_eq!(depth_of(&b.nodes), Some(b.depth));
    assert!(b.depth <= STACK_DEPTH, "depth {}", b.depth);
    let ulps = |x: f32| x.abs().max(1.0) * 1e-5;
    for n in &b.nodes {
        let mut inner = 0;
        for c in 0..8 {
            let meta = n.meta[c];
            if meta == 0 {
                continue;
            }
            let (lo, hi) = child_box(n, c);
            if n.e_imask[3] & (1 << c) != 0 {
                inner += 1;
                continue;
            }
            let first = n.prim_base + (meta & 0x1f) as u32;
            for s in first..first + (meta >> 5).count_ones() {
                let i = b.order[s as usize] as usize;
                seen[i] += 1;
                for a in 0..3 {
                    assert!(
                        lo[a] <= prims[i].min[a] + ulps(lo[a]),
                        "{lo:?} {:?}",
                        prims[i]
                    );
                    assert!(
                        hi[a] >= prims[i].max[a] - ulps(hi[a]),
                        "{hi:?} {:?}",
                        prims[i]
                    );
                }
            }
        }
        assert_eq!(inner, n.e_imask[3].count_ones());
    }
    assert!(seen.iter().all(|&s| s == 1), "{seen:?}");
}

#[test]
fn every_primitive_is_in_one_leaf_that_contains_it() {
    for n in [1usize, 2, 3, 4, 9, 100, 3000] {
        let prims = unit_boxes(n);
        check(&prims, &build(&prims));
    }
}

/// Chains far deeper than the stack (nested boxes; copies of one box) come out within it,
/// and a binary tree bounded to a height is exactly that high at most.
#[test]
fn deep_chains_are_bounded() {
    for prims in [nested_boxes(3000), vec![unit_boxes(1)[0]; 100_000]] {
        let t = std::time::Instant::now();
        let b = build(&prims);
        println!(
            "{} prims: CWBVH depth {}, built in {:.3} s",
            prims.len(),
            b.depth,
            t.elapsed().as_secs_f64()
        );
        check(&prims, &b);
        if prims.len() > 10_000 {
            continue; // copies of one box: raw PLOC would be quadratic
        }
        let params = BvhBuildParams::medium_build();
        let bvh2 = crate::accel::ploc(&prims, &params);
        let before = heights(&bvh2).0[0] as usize;
        for limit in [STACK_DEPTH, 16] {
            if let Some(bounded) = bound_height(&bvh2, &prims, limit) {
                let (h, count) = heights(&bounded);
                assert!(h[0] as usize <= limit, "{} > {limit}", h[0]);
                assert_eq!(count[0], prims.len() as u64);
                let cw = convert(&bounded, &mut Phases::default());
                assert!(cw.depth <= limit, "{} > {limit}", cw.depth);
                check(&prims, &cw);
            } else {
                assert!(before <= limit);
            }
        }
    }
}

#[test]
fn depth_of_rejects_what_is_not_a_tree() {
    let mut b = build(&unit_boxes(500));
    assert!(depth_of(&b.nodes).is_some());
    let root = b.nodes[0];
    assert!(root.e_imask[3] != 0);
    b.nodes[0].child_base = 0; // a cycle back to the root
    assert_eq!(depth_of(&b.nodes), None);
    b.nodes[0].child_base = 1 << 30; // out of range
    assert_eq!(depth_of(&b.nodes), None);
    b.nodes[0] = root;
    b.nodes[0].prim_base = 1 << 30;
    assert!(!leaves_in_range(&b.nodes, b.order.len()) || root.e_imask[3] == 0xff);
}

#[test]
fn empty_scene_has_a_root_without_children() {
    let b = build(&[]);
    assert_eq!(b.nodes.len(), 1);
    assert_eq!(b.nodes[0].meta, [0; 8]);
    assert_eq!(depth_of(&b.nodes), Some(1));
}

#[test]
fn copies_are_grouped_in_order_of_first_appearance() {
    let b = unit_boxes(3);
    let prims = [b[0], b[1], b[0], b[2], b[1], b[0]];
    let c = distinct_boxes(&prims);
    assert_eq!(c.reps, [0, 1, 3]);
    assert_eq!(c.members(0), [0, 2, 5]);
    assert_eq!(c.members(1), [1, 4]);
    assert_eq!(c.members(2), [3]);
    // Without copies, the identity and nothing else.
    let d = distinct_boxes(&b);
    assert_eq!(d.reps, [0, 1, 2]);
    assert!(d.members.is_empty());
    // The tree over the copies still holds every primitive once.
    check(&prims, &build(&prims));
}

/// The reference for `expand_copies` (its former, serial form): `bvh`, built over the distinct boxes, with each leaf (one distinct box) replaced by a
/// balanced subtree over the primitives of that box (`copies`), one primitive per leaf.
fn expand_copies_top_down(bvh: &Bvh2, prims: &[PrimBounds], copies: &Copies) -> Bvh2 {
    enum Task {
        Copy(usize, usize),
        Split(Vec<u32>, usize),
    }
    let mut nodes = vec![Bvh2Node::default()];
    let mut indices = Vec::with_capacity(prims.len());
    let mut tasks = vec![Task::Copy(0, 0)];
    while let Some(task) = tasks.pop() {
        match task {
            Task::Copy(i, out) => {
                let n = bvh.nodes[i];
                let f = n.first_index as usize;
                if n.prim_count > 0 {
                    let set = bvh.primitive_indices[f..f + n.prim_count as usize]
                        .iter()
                        .flat_map(|&r| copies.members(r).iter().copied())
                        .collect();
                    tasks.push(Task::Split(set, out));
                } else {
                    let c = nodes.len();
                    nodes.extend([Bvh2Node::default(); 2]);
                    nodes[out] = Bvh2Node::new(*n.aabb(), 0, c as u32);
                    tasks.push(Task::Copy(f, c));
                    tasks.push(Task::Copy(f + 1, c + 1));
                }
            }
            Task::Split(mut set, out) => {
                let b = prims[set[0] as usize];
                let aabb = Aabb::new(b.min.into(), b.max.into());
                if set.len() == 1 {
                    nodes[out] = Bvh2Node::new(aabb, 1, indices.len() as u32);
                    indices.push(set[0]);
                    continue;
                }
                let right = set.split_off(set.len() / 2);
                let c = nodes.len();
                nodes.extend([Bvh2Node::default(); 2]);
                nodes[out] = Bvh2Node::new(aabb, 0, c as u32);
                tasks.push(Task::Split(set, c));
                tasks.push(Task::Split(right, c + 1));
            }
        }
    }
    Bvh2 {
        nodes,
        primitive_indices: indices,
        ..Default::default()
    }
}

/// Expanding copies in place gives the tree the top-down copy gives: the same wide tree and
/// primitive order after the conversion, on boxes with many copies and with a few.
#[test]
fn expanding_copies_in_place_matches_the_top_down_copy() {
    let mut few = unit_boxes(2000);
    for i in (0..2000).step_by(97) {
        few[i + 1] = few[i];
    }
    let mut many = unit_boxes(300);
    many.extend(unit_boxes(300));
    many.extend(vec![unit_boxes(1)[0]; 500]);
    for prims in [few, many] {
        let copies = distinct_boxes(&prims);
        assert!(copies.reps.len() < prims.len());
        let reps: Vec<PrimBounds> = copies.reps.iter().map(|&i| prims[i as usize]).collect();
        let params = BvhBuildParams::medium_build();
        let mut bvh2 = crate::accel::ploc(&reps, &params);
        ReinsertionOptimizer::default().run(&mut bvh2, params.reinsertion_batch_ratio, None);
        let reference = expand_copies_top_down(&bvh2, &prims, &copies);
        let in_place = expand_copies(bvh2, &prims, &copies);
        assert_eq!(in_place.primitive_indices.len(), prims.len());
        let mut ph = Phases::default();
        let (a, b) = (convert(&reference, &mut ph), convert(&in_place, &mut ph));
        assert_eq!(
            bytemuck::cast_slice::<_, u8>(&a.nodes),
            bytemuck::cast_slice::<_, u8>(&b.nodes)
        );
        assert_eq!(a.order, b.order);
        let mut sorted = b.order.clone();
        sorted.sort_unstable();
        assert!(sorted.iter().enumerate().all(|(i, &p)| p as usize == i));
    }
}

/// The parallel conversion (cwbvh_convert.rs) is obvhs's serial one, node for node and bit for
/// bit, over trees large enough to take its parallel paths (4 wide levels, 14 binary ones), with
/// copies expanded and a nested chain bounded as `build` does.
#[test]
fn parallel_conversion_is_obvhs_s() {
    let params = obvhs::BvhBuildParams::medium_build();
    let nested = nested_boxes(3000);
    let mut chain = super::super::ploc(&nested, &params);
    if let Some(b) = bound_height(&chain, &nested, BINARY_LIMIT) {
        chain = b;
    }
    let mut cases = vec![("nested", chain)];
    for (name, prims) in [
        ("scattered", random_boxes(40_000, 7)),
        ("grid", unit_boxes(30_000)),
        ("few", random_boxes(5, 3)),
        ("one", random_boxes(1, 3)),
    ] {
        let mut bvh = super::super::ploc(&prims, &params);
        ReinsertionOptimizer::default().run(&mut bvh, params.reinsertion_batch_ratio, None);
        cases.push((name, bvh));
    }
    // Copies of boxes (1 to many of each), as `build` makes their tree: PLOC over the distinct
    // boxes, then each leaf expanded into a subtree over its copies (exact cost ties).
    let base = unit_boxes(300);
    let copied: Vec<PrimBounds> = (0..3000).map(|i| base[(i * i + 3 * i) % 300]).collect();
    let copies = distinct_boxes(&copied);
    assert!(copies.reps.len() < copied.len(), "copies to expand");
    let reps: Vec<PrimBounds> = copies.reps.iter().map(|&r| copied[r as usize]).collect();
    let mut bvh = super::super::ploc(&reps, &params);
    ReinsertionOptimizer::default().run(&mut bvh, params.reinsertion_batch_ratio, None);
    cases.push(("copies", expand_copies(bvh, &copied, &copies)));
    // (And the height check that skips bounding: the post-order arrays' height.)
    for (name, bvh) in &cases {
        assert_eq!(height_of(bvh), heights(bvh).0[0] as usize, "{name}");
    }
    let unbounded = super::super::ploc(&nested, &params);
    assert!(height_of(&unbounded) > BINARY_LIMIT);
    assert_eq!(height_of(&unbounded), heights(&unbounded).0[0] as usize);
    for (name, bvh) in &cases {
        let want = obvhs::cwbvh::bvh2_to_cwbvh::bvh2_to_cwbvh(bvh, MAX_LEAF, true, false);
        let got = bvh2_to_cwbvh(bvh, MAX_LEAF, &mut Phases::default());
        let slots = (got.primitive_indices.len(), want.primitive_indices.len());
        assert_eq!(slots.0, slots.1, "{name}: leaf slots");
        let differ = (0..slots.0).find(|&i| got.primitive_indices[i] != want.primitive_indices[i]);
        assert_eq!(differ, None, "{name}: first differing leaf slot");
        assert_eq!(got.nodes.len(), want.nodes.len(), "{name}");
        let differ = got
            .nodes
            .iter()
            .zip(&want.nodes)
            .position(|(a, b)| bytemuck::bytes_of(a) != bytemuck::bytes_of(b));
        assert_eq!(differ, None, "{name}: first differing node");
        // The large trees reach below the four parallel wide levels.
        let depth = depth_of(bytemuck::cast_slice(&got.nodes)).expect("a tree");
        assert!(
            depth > 5 || !["scattered", "grid"].contains(name),
            "{name}: {depth} wide levels"
        );
        println!(
            "{name}: {} wide nodes, {depth} levels, the same",
            got.nodes.len()
        );
    }
}

/// Trees of a few primitives are sparse (one or three children at the root), meshes are not.
#[test]
fn few_primitives_make_a_sparse_tree() {
    let tree = |prims: &[PrimBounds]| Cwbvh {
        nodes: build(prims).nodes,
        prims: Vec::new(),
    };
    let one = tree(&unit_boxes(1));
    assert_eq!(one.mean_children(), 1.0);
    assert!(one.sparse());
    let three = tree(&unit_boxes(3));
    assert_eq!(three.mean_children(), 3.0);
    assert!(three.sparse());
    let mesh = tree(&random_boxes(5000, 3));
    assert!(mesh.mean_children() > 6.0, "{}", mesh.mean_children());
    assert!(!mesh.sparse());
    assert!(tree(&[]).sparse());
}
