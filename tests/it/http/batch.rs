//! `batch` with per-patch emission states: solved together, equal to the single solves,
//! linear; and the hierarchical mode's refusal of batches over its work limit.

use axum::http::StatusCode;
use relight::color::Rgb;
use relight::input_limits::MAX_EMISSION_SWEEP_WORK;
use relight::model::batch::hierarchy_sweep_work;
use relight::server::{router, AppState};
use relight::transport::transfer::SOLVE_CHUNK;
use serde_json::{json, Value};

use super::{app, config, floats, post, ready};
use crate::common;

/// Issue #27: 1,000 single-patch emission states in the Cornell box were solved one by
/// one (0.1–0.3 s each) and ran into the request timeout. Now they are solved together,
/// a chunk at a time; the answers must be those of the single solves, in request order.
#[tokio::test]
async fn batched_emission_states_were_solved_one_by_one_into_the_timeout() {
    let _gate = common::shared();
    let r = ready("cornell-box");
    let t = &r.model.baked.transfer;
    let n = t.n;
    // More single-patch states than one chunk holds, so two chunks are solved; a
    // light-group state in between, and last the sum of all the single patches.
    let count = SOLVE_CHUNK + 5;
    let patches: Vec<usize> = (0..count).map(|k| (k * 41 + 7) % n).collect();
    let colour = |k: usize| [1.0 + (k % 3) as f32, 2.0, 0.5 * (k % 5) as f32];
    let mut states: Vec<Value> = patches
        .iter()
        .enumerate()
        .map(|(k, p)| json!({"emission": {p.to_string(): colour(k)}}))
        .collect();
    states.insert(60, json!({"lights": {"ceiling": 0.5}}));
    let mut sum = vec![0f32; 3 * n];
    for (k, &p) in patches.iter().enumerate() {
        for c in 0..3 {
            sum[3 * p + c] += colour(k)[c];
        }
    }
    let sum_pairs: Vec<[f32; 3]> = sum.chunks(3).map(|v| [v[0], v[1], v[2]]).collect();
    states.push(json!({ "emission": sum_pairs }));
    let body = json!({"states": states, "radiosity": true, "surfaces": ["floor"]});
    let (s, _, v) = post(app(), "/api/scenes/cornell-box/batch", body.to_string()).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let results = v["results"].as_array().unwrap();
    assert_eq!(results.len(), count + 2);
    let b = |k: usize| floats(&results[k]["radiosity"]);

    // The group state is the weighted sum of the columns, exactly.
    assert_eq!(b(60), t.relight(&[Rgb::splat(0.5)]).b);
    // Each emission state equals its own solve (the single-solve path of
    // `POST /radiosity`), to f32 rounding of the differently blocked solves: checked on
    // the states at both ends of each chunk and around the group state, and on every
    // 16th (one solve each takes 0.1–0.3 s); the superposition below covers them all.
    let singles: Vec<usize> = (0..count + 1).filter(|&k| k != 60).collect();
    let checked = |k: usize| {
        k.is_multiple_of(16)
            || [
                1,
                59,
                61,
                SOLVE_CHUNK - 1,
                SOLVE_CHUNK,
                SOLVE_CHUNK + 1,
                count,
            ]
            .contains(&k)
    };
    let mut total = vec![0f64; 3 * n];
    for (j, &k) in singles.iter().enumerate() {
        let got = b(k);
        assert_eq!(got.len(), 3 * n);
        for (t, g) in total.iter_mut().zip(&got) {
            *t += *g as f64;
        }
        // The emitted power is the patch's area times its exitance.
        let emitted = results[k]["power"]["emitted_lm"].as_f64().unwrap();
        let luminous = 0.2126 * colour(j)[0] + 0.7152 * colour(j)[1] + 0.0722 * colour(j)[2];
        let area = t.area[patches[j]] as f64;
        assert!(
            (emitted - area * luminous as f64).abs() <= 1e-6 * emitted,
            "{emitted}"
        );
        if !checked(k) {
            continue;
        }
        let mut e = vec![0f32; 3 * n];
        e[3 * patches[j]..3 * patches[j] + 3].copy_from_slice(&colour(j));
        let want = t.solve(&e).unwrap();
        let scale = want.b.iter().fold(0f32, |m, x| m.max(x.abs()));
        for (i, (g, w)) in got.iter().zip(&want.b).enumerate() {
            assert!(
                (g - w).abs() <= 1e-5 * scale,
                "state {k} (patch {}), B[{i}]: {g} vs {w}",
                patches[j],
            );
        }
    }
    // Superposition: the sum of the single-patch answers is the answer for the summed
    // emission.
    let summed = b(count + 1);
    let scale = summed.iter().fold(0f32, |m, x| m.max(x.abs())) as f64;
    assert!(scale > 0.0);
    for i in 0..3 * n {
        assert!(
            (summed[i] as f64 - total[i]).abs() <= 1e-4 * scale,
            "B[{i}]: {} vs {}",
            summed[i],
            total[i]
        );
    }
    // One of the states through `POST /radiosity`, the single request.
    let p = patches[3];
    let one = json!({"emission": {p.to_string(): colour(3)}});
    let (s, _, v1) = post(app(), "/api/scenes/cornell-box/radiosity", one.to_string()).await;
    assert_eq!(s, StatusCode::OK, "{v1}");
    let single = floats(&v1["radiosity"]);
    let scale = single.iter().fold(0f32, |m, x| m.max(x.abs()));
    for (a, b) in b(3).iter().zip(&single) {
        assert!((a - b).abs() <= 1e-5 * scale);
    }
}

/// A closed room (the hierarchical tests' room) baked in hierarchical mode, served.
fn hierarchical_room() -> (tempfile::TempDir, std::sync::Arc<AppState>) {
    let room = crate::hierarchical::closed_room();
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("room");
    std::fs::create_dir(&scene).unwrap();
    for f in ["scene.obj", "scene.mtl"] {
        std::fs::copy(room.path().join(f), scene.join(f)).unwrap();
    }
    let toml = std::fs::read_to_string(room.path().join("scene.toml")).unwrap();
    std::fs::write(
        scene.join("scene.toml"),
        format!("transfer = \"hierarchical\"\n{toml}"),
    )
    .unwrap();
    let s = AppState::new(config(dir.path().into(), dir.path().join("cache"))).unwrap();
    s.bake_all();
    (dir, s)
}

#[tokio::test]
async fn hierarchical_batches_over_the_sweep_limit_are_refused_up_front() {
    let _gate = common::shared();
    let (_dir, s) = hierarchical_room();
    let r = s.slot("room").unwrap().ready().unwrap();
    let t = &r.model.baked.transfer;
    assert!(t.hierarchy.is_some());
    let n = t.n;
    // A few emission states are solved together, each as its own solve would be.
    let states: Vec<Value> = (0..4)
        .map(|k| json!({"emission": {(k * 97 % n).to_string(): [1, 2, 3]}}))
        .collect();
    let (st, _, v) = post(
        router(s.clone()),
        "/api/scenes/room/batch",
        json!({"states": states, "radiosity": true}).to_string(),
    )
    .await;
    assert_eq!(st, StatusCode::OK, "{v}");
    for k in 0..4 {
        let mut e = vec![0f32; 3 * n];
        e[3 * (k * 97 % n)..3 * (k * 97 % n) + 3].copy_from_slice(&[1.0, 2.0, 3.0]);
        let want = t.solve(&e).unwrap();
        let got = floats(&v["results"][k]["radiosity"]);
        let scale = want.b.iter().fold(0f32, |m, x| m.max(x.abs()));
        assert_eq!(got.len(), 3 * n);
        for (i, (g, w)) in got.iter().zip(&want.b).enumerate() {
            assert!((g - w).abs() <= 1e-4 * scale, "state {k}, B[{i}]");
        }
    }
    // Just over the limit: refused before any work, naming the limit and what fits.
    let per_state = hierarchy_sweep_work(t, 1);
    let fits = (MAX_EMISSION_SWEEP_WORK / per_state) as usize;
    let over = fits + 1;
    assert!(
        over <= 1000,
        "the room fits {fits} states; the test needs a larger scene"
    );
    assert!(hierarchy_sweep_work(t, over) > MAX_EMISSION_SWEEP_WORK);
    let states: Vec<Value> = (0..over)
        .map(|k| json!({"emission": {(k % n).to_string(): [1, 1, 1]}}))
        .collect();
    let t0 = std::time::Instant::now();
    let (st, _, v) = post(
        router(s.clone()),
        "/api/scenes/room/batch",
        json!({ "states": states }).to_string(),
    )
    .await;
    let took = t0.elapsed();
    assert_eq!(st, StatusCode::UNPROCESSABLE_ENTITY, "{v}");
    let detail = v["detail"].as_str().unwrap();
    assert!(detail.contains("MAX_EMISSION_SWEEP_WORK"), "{detail}");
    assert!(
        detail.contains(&format!("at most {fits} emission states")),
        "{detail}"
    );
    eprintln!("refused {over} states in {took:?}: {detail}");
}
