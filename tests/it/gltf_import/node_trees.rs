//! glTF node hierarchies must be disjoint strict trees (one parent per node, a child named
//! once, roots without a parent, no cycles). Files that break the rule are refused before
//! the walk, with the node named; before, a child named ten times at each of eight levels
//! was walked as 10⁸ instances and never finished loading.
//!
//! `forest` also generates trees, with one fault or none, for the fuzz tests
//! (`fuzz::gltf`) and the upload tests (`http::upload`).

use proptest::prelude::*;
use serde_json::{json, Value};

use super::{folder, glb, load, load_err, unit_square, Doc};
use crate::common;

/// A .glb of one square mesh, a node per entry of `children` (each instancing the mesh),
/// and one scene listing `roots` (no scenes when None).
pub(crate) fn tree_glb(children: &[Vec<usize>], roots: Option<&[usize]>) -> Vec<u8> {
    let mut d = Doc::default();
    let (p, i) = unit_square(&mut d);
    let nodes: Vec<Value> = children
        .iter()
        .enumerate()
        .map(|(k, c)| {
            let mut n = json!({"mesh": 0, "translation": [2 * k, 0, 0]});
            if !c.is_empty() {
                n["children"] = json!(c);
            }
            n
        })
        .collect();
    let mut rest = json!({
        "meshes": [{"primitives": [{"attributes": {"POSITION": p}, "indices": i}]}],
        "nodes": nodes,
    });
    if let Some(r) = roots {
        rest["scenes"] = json!([{"nodes": r}]);
        rest["scene"] = json!(0);
    }
    glb(&d.json(rest, None), &d.bin)
}

/// A generated node hierarchy: children per node, the scene's roots, and the phrase the
/// refusal must contain (None: a strict forest, which loads).
#[derive(Clone, Debug)]
pub(crate) struct Forest {
    pub(crate) children: Vec<Vec<usize>>,
    pub(crate) roots: Vec<usize>,
    pub(crate) fault: Option<&'static str>,
}

impl Forest {
    pub(crate) fn glb(&self) -> Vec<u8> {
        tree_glb(&self.children, Some(&self.roots))
    }
}

/// Random forests of 3 to 15 nodes (node 1 always under node 0), each with no fault (one
/// case in five) or one of: a child named again by its parent (possibly many times), a
/// child shared with a second parent, a child listed as a scene root, or a root hung below
/// itself or one of its descendants (a cycle).
pub(crate) fn forest() -> impl Strategy<Value = Forest> {
    (
        3usize..16,
        proptest::collection::vec(any::<u32>(), 16),
        0u8..5,
        any::<u32>(),
        any::<u32>(),
        1usize..12,
    )
        .prop_map(|(n, picks, fault, a, b, times)| {
            let (a, b) = (a as usize, b as usize);
            let mut parent = vec![None; n];
            parent[1] = Some(0);
            for (i, pick) in picks.iter().enumerate().take(n).skip(2) {
                let p = *pick as usize % (i + 1);
                parent[i] = (p < i).then_some(p);
            }
            let mut children = vec![Vec::new(); n];
            for (i, p) in parent.iter().enumerate() {
                if let Some(p) = p {
                    children[*p].push(i);
                }
            }
            let mut roots: Vec<usize> = (0..n).filter(|&i| parent[i].is_none()).collect();
            let under: Vec<usize> = (0..n).filter(|&i| parent[i].is_some()).collect();
            let c = under[a % under.len()];
            let p = parent[c].unwrap_or(0);
            let fault = match fault {
                1 => {
                    for _ in 0..times {
                        let at = b % (children[p].len() + 1);
                        children[p].insert(at, c);
                    }
                    Some("appears twice in the children of")
                }
                2 => {
                    let others: Vec<usize> = (0..n).filter(|&q| q != c && q != p).collect();
                    children[others[b % others.len()]].push(c);
                    Some("has two parents")
                }
                3 => {
                    roots.insert(b % (roots.len() + 1), c);
                    Some("which is the child of")
                }
                4 => {
                    let r = roots[a % roots.len()];
                    let mut below = vec![r];
                    let mut k = 0;
                    while k < below.len() {
                        below.extend(children[below[k]].iter().copied());
                        k += 1;
                    }
                    let d = below[b % below.len()];
                    children[d].push(r);
                    roots.retain(|&x| x != r);
                    Some(if d == r {
                        "is its own child"
                    } else {
                        "is its own ancestor"
                    })
                }
                _ => None,
            };
            Forest {
                children,
                roots,
                fault,
            }
        })
}

/// The error loading `bytes` as `x.glb`, which must name the file.
fn refused(bytes: &[u8]) -> String {
    let dir = folder(&[("x.glb", bytes)]);
    let e = load_err(dir.path());
    assert!(e.contains("x.glb"), "{e}");
    e
}

#[test]
fn a_child_named_ten_times_eight_deep_was_expanded_to_1e8_instances() {
    let _gate = common::shared();
    // nodes[k] names nodes[k + 1] ten times, eight levels down to a mesh: 10⁸ instances.
    let mut children: Vec<Vec<usize>> = (0..8).map(|k| vec![k + 1; 10]).collect();
    children.push(Vec::new());
    for roots in [Some(&[0][..]), None] {
        let e = refused(&tree_glb(&children, roots));
        assert!(
            e.contains("nodes[1] appears twice in the children of nodes[0]"),
            "{e}"
        );
    }
    // Shared subtrees that double at every level (2^40 instances): the same refusal.
    let mut children: Vec<Vec<usize>> = (0..40).map(|k| vec![k + 1, k + 1]).collect();
    children.push(Vec::new());
    let e = refused(&tree_glb(&children, Some(&[0])));
    assert!(
        e.contains("nodes[1] appears twice in the children of nodes[0]"),
        "{e}"
    );
}

#[test]
fn a_node_under_two_parents_is_refused_naming_both() {
    let _gate = common::shared();
    // A diamond: nodes[3] under nodes[1] and under nodes[2].
    let children = vec![vec![1, 2], vec![3], vec![3], vec![]];
    let e = refused(&tree_glb(&children, Some(&[0])));
    assert!(
        e.contains("nodes[3] has two parents: nodes[1] and nodes[2]"),
        "{e}"
    );
    // Two roots sharing a child: the same, with or without a scene.
    let children = vec![vec![2], vec![2], vec![]];
    for roots in [Some(&[0, 1][..]), None] {
        let e = refused(&tree_glb(&children, roots));
        assert!(
            e.contains("nodes[2] has two parents: nodes[0] and nodes[1]"),
            "{e}"
        );
    }
}

#[test]
fn a_root_that_is_also_a_child_is_refused() {
    let _gate = common::shared();
    let children = vec![vec![1], vec![2], vec![]];
    let e = refused(&tree_glb(&children, Some(&[0, 2])));
    assert!(
        e.contains("scenes[0].nodes names nodes[2], which is the child of nodes[1]"),
        "{e}"
    );
    // A root listed twice would be walked twice.
    let e = refused(&tree_glb(&children, Some(&[0, 0])));
    assert!(e.contains("scenes[0].nodes names nodes[0] twice"), "{e}");
}

#[test]
fn a_cycle_in_the_node_tree_is_refused() {
    let _gate = common::shared();
    // A node that is its own child, listed as a root or not.
    for roots in [Some(&[0][..]), None] {
        let e = refused(&tree_glb(&[vec![0]], roots));
        assert!(e.contains("nodes[0] is its own child"), "{e}");
    }
    // A loop of three below no root (with a separate, valid root), with or without a scene.
    let children = vec![vec![], vec![2], vec![3], vec![1]];
    for roots in [Some(&[0][..]), None] {
        let e = refused(&tree_glb(&children, roots));
        assert!(e.contains("is its own ancestor"), "{e}");
        assert!(["nodes[1]", "nodes[2]", "nodes[3]"]
            .iter()
            .any(|n| e.contains(&format!("{n} is its own ancestor"))));
    }
    // A root hung below its own child.
    let children = vec![vec![1], vec![0]];
    let e = refused(&tree_glb(&children, Some(&[0])));
    assert!(
        e.contains("which is the child of nodes[1]") || e.contains("own ancestor"),
        "{e}"
    );
}

#[test]
fn a_child_or_root_that_does_not_exist_is_refused() {
    let _gate = common::shared();
    // The crate's validation refuses the index before the tree is looked at.
    for (children, roots) in [(vec![vec![7]], vec![0]), (vec![vec![]], vec![3])] {
        let e = refused(&tree_glb(&children, Some(&roots)));
        assert!(e.contains("not a valid glTF 2.0 file"), "{e}");
    }
}

#[test]
fn a_tree_of_more_nodes_than_the_instance_limit_is_refused_before_meshes_are_read() {
    let _gate = common::shared();
    let n = relight::input_limits::MAX_GLTF_NODE_INSTANCES;
    // One root over n leaves, no meshes: n + 1 nodes.
    let mut d = Doc::default();
    unit_square(&mut d);
    let mut nodes = vec![json!({"children": (1..=n).collect::<Vec<_>>()})];
    nodes.resize(n + 1, json!({}));
    let doc = d.json(json!({"nodes": nodes, "scenes": [{"nodes": [0]}]}), None);
    let e = refused(&glb(&doc, &d.bin));
    assert!(e.contains(&format!("more than {n} nodes")), "{e}");
}

#[test]
fn strict_forests_load_with_every_node_once() {
    let _gate = common::shared();
    let children = vec![vec![1, 2], vec![3], vec![], vec![], vec![5], vec![]];
    for roots in [Some(&[0, 4][..]), None] {
        let dir = folder(&[("x.glb", &tree_glb(&children, roots))]);
        let s = load(dir.path());
        let names: std::collections::BTreeSet<&str> =
            s.surfaces.iter().map(|x| x.name.as_str()).collect();
        assert_eq!(names.len(), 6, "{names:?}");
    }
}
