//! Real answers of every operation, through the router, against the document.

use super::*;

/// A small room with every kind of thing an answer lists: an emissive light group and a
/// luminaire group (one luminaire with watts, one without), a two-sided surface, a work
/// plane and a list of points, a camera. Patches of 2 m: a few dozen.
fn small_room(dir: &std::path::Path) {
    fn quad(name: &str, mat: &str, p: [[f64; 3]; 4]) -> String {
        let mut s = format!("o {name}\nusemtl {mat}\n");
        for v in p {
            s += &format!("v {} {} {}\n", v[0], v[1], v[2]);
        }
        s + "f -4 -3 -2 -1\n"
    }
    // Corners counter-clockwise seen from the front (inside the room).
    let (x, y, z) = (4.0, 3.0, 4.0);
    #[rustfmt::skip]
    let quads = [
        ("floor", "white", [[0., 0., 0.], [0., 0., z], [x, 0., z], [x, 0., 0.]]),
        ("ceiling", "white", [[0., y, 0.], [x, y, 0.], [x, y, z], [0., y, z]]),
        ("west", "white", [[0., 0., 0.], [0., y, 0.], [0., y, z], [0., 0., z]]),
        ("east", "white", [[x, 0., 0.], [x, 0., z], [x, y, z], [x, y, 0.]]),
        ("north", "white", [[0., 0., 0.], [x, 0., 0.], [x, y, 0.], [0., y, 0.]]),
        ("south", "white", [[0., 0., z], [0., y, z], [x, y, z], [x, 0., z]]),
        ("panel", "light", [[1.5, 2.9, 1.5], [2.5, 2.9, 1.5], [2.5, 2.9, 2.5], [1.5, 2.9, 2.5]]),
        ("shelf", "white", [[0.5, 1., 0.5], [0.5, 1., 1.5], [1.5, 1., 1.5], [1.5, 1., 0.5]]),
    ];
    let obj: String = quads.map(|(name, mat, p)| quad(name, mat, p)).concat();
    let mtl = "newmtl white\nKd 0.7 0.7 0.7\nnewmtl light\nKd 0 0 0\nKe 10 10 10\n";
    let toml = r#"
name = "Small room"
units = "m"
transfer = "factored"
[site]
latitude = 40.4
longitude = -3.7
timezone = 1
[mesh]
max_edge = 2.0
[surface.shelf]
two_sided = true
[[lights]]
id = "panel"
name = "Ceiling panel"
surfaces = ["panel"]
[[lights]]
id = "lamps"
name = "Lamps"
intensity = 0.9
color = [1.0, 0.9, 0.8]
[[luminaires]]
id = "bulb"
group = "lamps"
position = [3, 2, 3]
lumens = 800
watts = 8
[[luminaires]]
id = "spot"
group = "lamps"
position = [1, 2.5, 3]
distribution = "spot"
beam_deg = 30
field_deg = 60
lumens = 500
[[grids]]
id = "desk"
name = "Desk"
min = [0.5, 0.5]
max = [3.5, 3.5]
height = 0.75
spacing = 1.0
[[grids]]
id = "probes"
points = [[2, 0.5, 2], [3, 0.5, 1]]
[[cameras]]
id = "door"
position = [3.5, 1.6, 0.5]
target = [2, 1, 2]
fov_deg = 60
"#;
    std::fs::create_dir_all(dir).unwrap();
    std::fs::write(dir.join("scene.obj"), format!("mtllib scene.mtl\n{obj}")).unwrap();
    std::fs::write(dir.join("scene.mtl"), mtl).unwrap();
    std::fs::write(dir.join("scene.toml"), toml).unwrap();
    std::fs::write(
        dir.join("weather.epw"),
        include_bytes!("../../../../tests/data/weather/mannheim.epw"),
    )
    .unwrap();
}

/// Sends requests to a router and checks every answer against what the document says of
/// its operation, status and content type.
struct Client {
    app: Router,
    doc: Value,
    /// (path, method, status) of the JSON answers checked.
    checked: BTreeSet<(String, String, u16)>,
}

impl Client {
    /// POST `body` to operation `op` of the scene `room` (`/api/scenes/room/<op>`).
    async fn post(&mut self, op: &str, body: Value) -> (StatusCode, Value) {
        let path = format!("/api/scenes/{{id}}/{op}");
        let uri = format!("/api/scenes/room/{op}");
        self.send("post", &path, &uri, Some(body)).await
    }

    /// `path` is the operation's path in the document; `uri` the request's.
    async fn send(
        &mut self,
        method: &str,
        path: &str,
        uri: &str,
        body: Option<Value>,
    ) -> (StatusCode, Value) {
        let req = Request::builder()
            .method(method.to_uppercase().as_str())
            .uri(uri);
        let req = match body {
            Some(b) => req
                .header(header::CONTENT_TYPE, "application/json")
                .body(Body::from(b.to_string())),
            None => req.body(Body::empty()),
        };
        let resp = self.app.clone().oneshot(req.unwrap()).await.unwrap();
        let status = resp.status();
        let ctype = resp.headers()[header::CONTENT_TYPE]
            .to_str()
            .unwrap()
            .to_string();
        let bytes = resp.into_body().collect().await.unwrap().to_bytes();
        let what = format!("{method} {uri} → {status} {ctype}");
        let op = &self.doc["paths"][path][method];
        assert!(op.is_object(), "{what}: no such operation");
        let mut answer = &op["responses"][status.as_str()];
        if let Some(r) = answer["$ref"].as_str() {
            answer = self.doc.pointer(r.strip_prefix('#').unwrap()).unwrap();
        }
        let media = ctype.split(';').next().unwrap().trim();
        let content = &answer["content"][media];
        assert!(content.is_object(), "{what}: undocumented answer");
        if !media.ends_with("json") {
            return (status, Value::Null);
        }
        let v: Value = serde_json::from_slice(&bytes).unwrap();
        if let Err(e) = validate(&self.doc, &content["schema"], &v, "answer") {
            panic!("{what}: the document does not describe the answer: {e}");
        }
        self.checked
            .insert((path.to_string(), method.to_string(), status.as_u16()));
        (status, v)
    }
}

/// Real answers of every operation, through the router, against the document: the
/// schemas derived from the answer types must describe what those types serialize to,
/// with each optional part present and absent.
#[tokio::test]
async fn real_answers_match_the_document() {
    let root = tempfile::tempdir().unwrap();
    let scenes = root.path().join("scenes");
    small_room(&scenes.join("room"));
    // A scene that fails to load.
    std::fs::create_dir_all(scenes.join("broken")).unwrap();
    std::fs::write(scenes.join("broken/scene.obj"), "v 0 0 0\nf 1 2 3\n").unwrap();
    let config = ServerConfig {
        scenes,
        cache: root.path().join("cache"),
        ..ServerConfig::default()
    };
    let state = AppState::new(config).unwrap();
    let mut c = Client {
        app: router(state.clone()),
        doc: spec(),
        checked: BTreeSet::new(),
    };
    // Queued.
    let (s, v) = c.send("get", "/readyz", "/readyz", None).await;
    assert_eq!(
        (s, &v["ready"]),
        (StatusCode::SERVICE_UNAVAILABLE, &json!(false))
    );
    c.send("get", "/api/scenes", "/api/scenes", None).await;
    let (s, _) = c
        .send("get", "/api/scenes/{id}", "/api/scenes/room", None)
        .await;
    assert_eq!(s, StatusCode::SERVICE_UNAVAILABLE);
    tokio::task::spawn_blocking({
        let state = state.clone();
        move || state.bake_all()
    })
    .await
    .unwrap();
    let (s, v) = c.send("get", "/readyz", "/readyz", None).await;
    assert_eq!(s, StatusCode::OK);
    let statuses: Vec<&Value> = v["scenes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| &s["status"])
        .collect();
    assert_eq!(statuses, ["failed", "ready"], "{v}");
    c.send("get", "/api/scenes", "/api/scenes", None).await;
    let (s, _) = c
        .send("get", "/api/scenes/{id}", "/api/scenes/broken", None)
        .await;
    assert_eq!(s, StatusCode::SERVICE_UNAVAILABLE);
    let (s, _) = c
        .send("get", "/api/scenes/{id}", "/api/scenes/atlantis", None)
        .await;
    assert_eq!(s, StatusCode::NOT_FOUND);

    ask_every_query(&mut c).await;
    assert_every_operation_checked(&c);
}

/// The queries of the ready scene: details, patches, radiosity, illuminance, batch,
/// optimize and glare, each checked against the document as it is answered.
async fn ask_every_query(c: &mut Client) {
    let (s, v) = c
        .send("get", "/api/scenes/{id}", "/api/scenes/room", None)
        .await;
    assert_eq!(s, StatusCode::OK);
    assert_eq!(v["luminaires"].as_array().unwrap().len(), 2);
    assert_eq!(v["grids"][0]["layout"], json!([3, 3]), "{}", v["grids"]);
    assert!(v["grids"][1]["layout"].is_null());
    assert!(v["lights"][1]["watts"].is_null());
    let surfaces = v["surfaces"].as_array().unwrap();
    assert!(surfaces.iter().any(|s| s["two_sided"] == true));
    c.send(
        "get",
        "/api/scenes/{id}/patches",
        "/api/scenes/room/patches",
        None,
    )
    .await;

    c.post("radiosity", json!({})).await;
    let (_, v) = c
        .post(
            "radiosity",
            json!({"quantity": "illuminance", "surfaces": true}),
        )
        .await;
    assert!(v["surfaces"].is_object() && v["illuminance"].is_array());
    let emission = json!({"emission": {"0": [1, 1, 1]}, "surfaces": true});
    c.post("radiosity", emission).await;
    let (s, _) = c.post("radiosity", json!({"lights": {"nope": 1}})).await;
    assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY);

    let (_, v) = c
        .post("illuminance", json!({"grids": ["desk", "probes"]}))
        .await;
    assert!(v["power"].is_object());
    let points = json!([{"position": [2, 1, 2], "normal": [0, 1, 0]}]);
    let (_, v) = c
        .post(
            "illuminance",
            json!({"emission": {"0": [1, 1, 1]}, "points": points}),
        )
        .await;
    assert!(
        v["power"].is_null() && v["points"].as_array().unwrap().len() == 1,
        "{v}"
    );

    let (_, v) = c
        .post(
            "daylight",
            json!({"sky": {"type": "cie_overcast", "horizontal_illuminance": 10000},
                "grids": ["desk"], "points": points, "lights": {"panel": 1}}),
        )
        .await;
    assert!(v["grids"]["desk"]["daylight_factor"].is_object(), "{v}");
    let (_, v) = c
        .post(
            "daylight",
            json!({"sky": {"type": "perez", "direct_normal_irradiance": 600,
                "diffuse_horizontal_irradiance": 120, "time": "2026-06-21T14:00"}}),
        )
        .await;
    assert!(
        v["sky"]["sun"].is_object() && v["surfaces"]["floor"].is_object(),
        "{v}"
    );
    let (s, _) = c
        .post("daylight", json!({"sky": {"type": "overcast"}}))
        .await;
    assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY);
    let (_, v) = c
        .post(
            "annual",
            json!({"weather": "weather.epw", "grids": ["desk"]}),
        )
        .await;
    assert!(v["grids"]["desk"]["en17037"].is_object(), "{v}");
    let (s, _) = c.post("annual", json!({"weather": "/etc/passwd"})).await;
    assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY);

    let batch = json!({"states": [{}, {"lights": {"lamps": 0.5}}], "surfaces": ["floor"], "radiosity": true, "grids": ["desk"]});
    let (_, v) = c.post("batch", batch).await;
    assert!(v["results"][1]["radiosity"].is_array() && v["results"][1]["grids"].is_object());
    let batch = json!({"states": [{"emission": {"0": [1, 1, 1]}}]});
    let (_, v) = c.post("batch", batch).await;
    let plain = v["results"][0].as_object().unwrap();
    assert!(
        !plain.contains_key("radiosity") && !plain.contains_key("grids"),
        "{v}"
    );

    let targets = json!({"targets": [{"grid": "desk", "eavg_min": 1.0, "u0_min": 0.1}]});
    c.post("optimize", targets).await;

    // The room's luminaires are point sources: both are left out, with the reason.
    let observers = json!({"observers": [{"position": [3.5, 0, 3.5], "direction": [-1, 0, -1]}]});
    let (_, v) = c.post("glare", observers).await;
    let o = &v["observers"][0];
    assert!(o["ugr"].is_null(), "{v}");
    assert_eq!(o["left_out"].as_array().unwrap().len(), 2, "{v}");
}

/// Every operation's JSON answer was checked.
fn assert_every_operation_checked(c: &Client) {
    for (path, item) in c.doc["paths"].as_object().unwrap() {
        for (method, op) in item.as_object().unwrap() {
            let json_ok = op["responses"]["200"]["content"]
                .as_object()
                .is_some_and(|m| m.contains_key("application/json"));
            let key = (path.clone(), method.clone(), 200);
            if json_ok && path != "/api/openapi.json" {
                assert!(
                    c.checked.contains(&key),
                    "{method} {path}: no answer checked"
                );
            }
        }
    }
}
