//! The node hierarchy, checked before anything is expanded.
//!
//! glTF 2.0 requires the nodes to form disjoint strict trees: every node has at most one
//! parent (and appears once in its parent's `children`), no node is its own ancestor, and a
//! scene's root nodes have no parent. [`roots`] checks exactly that in one pass over the
//! nodes, their child lists and the scenes, O(nodes + edges), before a mesh is decoded. The
//! walk from the roots then visits every node once: a file cannot multiply instances by
//! naming a child many times or sharing a subtree (ten copies of a child, eight levels
//! deep, would otherwise be 10⁸ instances of one mesh).

use crate::input_limits::{MAX_GLTF_DEPTH, MAX_GLTF_NODE_INSTANCES};

/// No parent, no depth, not listed.
const NONE: usize = usize::MAX;

/// The root nodes to walk, in order: the default scene's, else the first scene's, else (a
/// file without scenes) every node without a parent. Checks first that the hierarchy is a
/// forest of strict trees, then that the walk from these roots stays within
/// [`MAX_GLTF_NODE_INSTANCES`] nodes and [`MAX_GLTF_DEPTH`] levels. Errors name the node.
pub(super) fn roots(doc: &gltf::Document) -> Result<Vec<usize>, String> {
    let json = doc.as_json();
    let parent = parents(json)?;
    check_scenes(json, &parent)?;
    let depth = depths(json, &parent)?;
    let roots: Vec<usize> = match doc.default_scene().or_else(|| doc.scenes().next()) {
        Some(s) => s.nodes().map(|r| r.index()).collect(),
        None => (0..parent.len()).filter(|&i| parent[i] == NONE).collect(),
    };
    check_walk(json, &roots, &depth)?;
    Ok(roots)
}

/// The children of node `p`.
fn children(json: &gltf::json::Root, p: usize) -> impl Iterator<Item = usize> + '_ {
    json.nodes[p].children.iter().flatten().map(|c| c.value())
}

/// Checks that node `i` exists; `what` names where the file names it.
fn exists(json: &gltf::json::Root, i: usize, what: &dyn Fn() -> String) -> Result<(), String> {
    let n = json.nodes.len();
    if i < n {
        Ok(())
    } else {
        Err(format!(
            "{} names nodes[{i}], which does not exist (the file has {n} nodes)",
            what()
        ))
    }
}

/// Each node's parent ([`NONE`] for none), once every child has one parent and names it
/// once.
fn parents(json: &gltf::json::Root) -> Result<Vec<usize>, String> {
    let n = json.nodes.len();
    let mut parent = vec![NONE; n];
    for p in 0..n {
        for c in children(json, p) {
            exists(json, c, &|| format!("nodes[{p}].children"))?;
            if c == p {
                return Err(format!(
                    "nodes[{p}] is its own child (a cycle in the node tree)"
                ));
            }
            match parent[c] {
                NONE => parent[c] = p,
                q if q == p => {
                    return Err(format!(
                        "nodes[{c}] appears twice in the children of nodes[{p}] (in glTF a \
                         node has one place in the tree; instance a mesh with several nodes)"
                    ))
                }
                q => {
                    return Err(format!(
                        "nodes[{c}] has two parents: nodes[{q}] and nodes[{p}] (in glTF a node \
                         has one place in the tree; instance a mesh with several nodes)"
                    ))
                }
            }
        }
    }
    Ok(parent)
}

/// Checks that a scene lists root nodes, each once.
fn check_scenes(json: &gltf::json::Root, parent: &[usize]) -> Result<(), String> {
    let mut listed = vec![NONE; parent.len()];
    for (s, scene) in json.scenes.iter().enumerate() {
        for r in scene.nodes.iter().map(|r| r.value()) {
            exists(json, r, &|| format!("scenes[{s}].nodes"))?;
            if parent[r] != NONE {
                return Err(format!(
                    "scenes[{s}].nodes names nodes[{r}], which is the child of nodes[{}] (a \
                     scene lists root nodes only)",
                    parent[r]
                ));
            }
            if listed[r] == s {
                return Err(format!("scenes[{s}].nodes names nodes[{r}] twice"));
            }
            listed[r] = s;
        }
    }
    Ok(())
}

/// Each node's depth below its parentless ancestor, once no node is its own ancestor.
fn depths(json: &gltf::json::Root, parent: &[usize]) -> Result<Vec<usize>, String> {
    let n = parent.len();
    // Down from the parentless nodes, each node is reached once (from its one parent). A
    // node never reached has a parent that is never reached either: it lies on a cycle or
    // below one, and its parents lead round the cycle.
    let mut depth = vec![NONE; n];
    let mut stack: Vec<usize> = (0..n).filter(|&i| parent[i] == NONE).collect();
    for &i in &stack {
        depth[i] = 0;
    }
    while let Some(p) = stack.pop() {
        for c in children(json, p) {
            depth[c] = depth[p] + 1;
            stack.push(c);
        }
    }
    if let Some(i) = (0..n).find(|&i| depth[i] == NONE) {
        let mut seen = vec![false; n];
        let mut k = i;
        while !seen[k] {
            seen[k] = true;
            k = parent[k];
        }
        return Err(format!(
            "nodes[{k}] is its own ancestor (a cycle in the node tree through nodes[{}])",
            parent[k]
        ));
    }
    Ok(depth)
}

/// Checks the walk's size and depth from `roots`, before it starts. In a strict tree the
/// walk visits each node once, so this is bounded by the node count; the limit bounds it
/// in absolute terms.
fn check_walk(json: &gltf::json::Root, roots: &[usize], depth: &[usize]) -> Result<(), String> {
    let mut stack = roots.to_vec();
    let mut count = 0usize;
    while let Some(p) = stack.pop() {
        count += 1;
        if count > MAX_GLTF_NODE_INSTANCES {
            return Err(format!(
                "the scene's node tree has more than {MAX_GLTF_NODE_INSTANCES} nodes"
            ));
        }
        if depth[p] >= MAX_GLTF_DEPTH {
            return Err(format!(
                "nodes[{p}]: the node tree is deeper than {MAX_GLTF_DEPTH} levels"
            ));
        }
        stack.extend(children(json, p));
    }
    Ok(())
}
