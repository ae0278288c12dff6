// Offline viewer of the WIT City Model tileset: CesiumJS with no imagery, no Ion, no network but this
// server. ?tileset=URL overrides the tileset (default 3dtiles/tileset.json beside the page); ?range=R sets the
// first view's distance in radii of the tileset's bounding sphere (default 1.2; larger: zoomed out), ?heading=
// and ?pitch= its direction in degrees (default -30 and -35: from the south-east, looking down obliquely);
// ?target=LON,LAT,HEIGHT (degrees, metres) with ?distance=M looks at that point from M metres instead, the same
// view of any tileset (before/after screenshots).
// The "Generated facades" switch shows walls with their generated facade textures (vertices marked _FACADE by
// the export) or in the plain wall colour: a custom shader, set only while they are switched off (it is
// disabled, by CesiumJS, on the primitives without that attribute).
// window.witViewer tells the tests and the benchmark what happened: state (loading, ready, error),
// errors, seconds until the first view was fully loaded, the tileset's bytes fetched until then, and measureFps().
"use strict";
const witViewer = (window.witViewer = { state: "loading", errors: [], loadSeconds: null, tileset: null });
const status = document.getElementById("status");

function fail(message) {
  witViewer.state = "error";
  witViewer.errors.push(String(message));
  status.textContent = "Error: " + message;
  console.error(message);
}

function showProperties(feature) {
  const table = document.getElementById("info-table");
  table.replaceChildren();
  let title = "";
  for (const id of feature.getPropertyIds()) {
    const value = feature.getProperty(id);
    if (value === undefined || value === null || value === "") continue;
    const row = table.insertRow();
    const key = row.insertCell();
    key.className = "key";
    key.textContent = id;
    row.insertCell().textContent = String(value);
    if (id === "BULD_NM") title = String(value);
  }
  document.getElementById("info-title").textContent = title || String(feature.getProperty("wit_id"));
  document.getElementById("info").hidden = false;
}

async function main() {
  performance.setResourceTimingBufferSize(100000);  // CesiumJS alone fetches more than the default 250
  const viewer = new Cesium.Viewer("map", {
    baseLayer: false, baseLayerPicker: false, geocoder: false, sceneModePicker: false, navigationHelpButton: false,
    animation: false, timeline: false, fullscreenButton: false, infoBox: false, selectionIndicator: false,
    homeButton: true, terrainProvider: new Cesium.EllipsoidTerrainProvider(),
  });
  witViewer.viewer = viewer;
  const scene = viewer.scene;
  scene.globe.baseColor = Cesium.Color.fromCssColorString("#3a4450");
  scene.globe.depthTestAgainstTerrain = false;
  scene.skyAtmosphere.show = true;
  scene.fog.enabled = false;
  const query = new URLSearchParams(location.search);
  const url = query.get("tileset") || "3dtiles/tileset.json";
  const range = Number(query.get("range")) || 1.2;  // camera distance in radii of the tileset's bounding sphere
  const heading = Number(query.get("heading") ?? -30);
  const pitch = Number(query.get("pitch") ?? -35);
  const started = performance.now();
  const tileset = await Cesium.Cesium3DTileset.fromUrl(url, { maximumScreenSpaceError: 16 });
  witViewer.tileset = tileset;
  scene.primitives.add(tileset);
  tileset.tileFailed.addEventListener((error) => fail(`tile ${error.url}: ${error.message}`));
  const radius = tileset.boundingSphere.radius;
  const direction = (distance) => new Cesium.HeadingPitchRange(Cesium.Math.toRadians(heading),
                                                                Cesium.Math.toRadians(pitch), distance);
  const target = query.get("target");
  if (target) {
    const [lon, lat, height] = target.split(",").map(Number);
    viewer.camera.lookAt(Cesium.Cartesian3.fromDegrees(lon, lat, height || 0),
                         direction(Number(query.get("distance")) || radius * range));
    viewer.camera.lookAtTransform(Cesium.Matrix4.IDENTITY);
  } else {
    await viewer.zoomTo(tileset, direction(radius * range));
  }
  // Ready: tiles have loaded, none is pending for this view, and two frames have been drawn since.
  let loadedTiles = 0;
  let settledFrames = 0;
  tileset.tileLoad.addEventListener(() => { loadedTiles += 1; });
  const removeWatch = scene.postRender.addEventListener(() => {
    settledFrames = loadedTiles > 0 && tileset.tilesLoaded ? settledFrames + 1 : 0;
    if (settledFrames < 2 || witViewer.state !== "loading") return;
    removeWatch();
    witViewer.loadSeconds = (performance.now() - started) / 1000;
    witViewer.loadedTiles = loadedTiles;
    witViewer.state = "ready";
    status.textContent = `Loaded in ${witViewer.loadSeconds.toFixed(2)} s — click a building for its attributes`;
  });

  const plainWalls = new Cesium.CustomShader({
    fragmentShaderText: `
      void fragmentMain(FragmentInput fsInput, inout czm_modelMaterial material) {
        material.diffuse = mix(material.diffuse, vec3(0.871, 0.835, 0.769), step(0.5, fsInput.attributes.facade));
      }`,
  });
  witViewer.showFacades = (show) => {
    tileset.customShader = show ? undefined : plainWalls;
    document.getElementById("facades-on").checked = show;
  };
  document.getElementById("facades-on").onchange = (event) => witViewer.showFacades(event.target.checked);

  let highlighted = null;
  new Cesium.ScreenSpaceEventHandler(scene.canvas).setInputAction((click) => {
    if (highlighted) highlighted.color = Cesium.Color.WHITE;
    highlighted = null;
    const picked = scene.pick(click.position);
    if (picked instanceof Cesium.Cesium3DTileFeature) {
      highlighted = picked;
      picked.color = Cesium.Color.fromCssColorString("#ffd966");
      showProperties(picked);
    } else {
      document.getElementById("info").hidden = true;
    }
  }, Cesium.ScreenSpaceEventType.LEFT_CLICK);
  document.getElementById("info-close").onclick = () => { document.getElementById("info").hidden = true; };
}

// Frames drawn per second over `seconds`, the scene re-rendered continuously (for the benchmark).
witViewer.measureFps = (seconds) => new Promise((resolve) => {
  const scene = witViewer.viewer.scene;
  let frames = 0;
  const count = () => { frames += 1; };
  scene.postRender.addEventListener(count);
  const start = performance.now();
  setTimeout(() => {
    scene.postRender.removeEventListener(count);
    resolve(frames / ((performance.now() - start) / 1000));
  }, seconds * 1000);
});

// Screen positions (CSS pixels) on a grid where a building is drawn, with its name: for a test's real click.
witViewer.buildingPixels = (step) => {
  const scene = witViewer.viewer.scene;
  const canvas = scene.canvas;
  const hits = [];
  for (let y = step; y < canvas.clientHeight; y += step) {
    for (let x = step; x < canvas.clientWidth; x += step) {
      const picked = scene.pick(new Cesium.Cartesian2(x, y));
      if (picked instanceof Cesium.Cesium3DTileFeature) hits.push([x, y, picked.getProperty("BULD_NM") || ""]);
    }
  }
  return hits;
};

main().catch((error) => fail(error && error.message ? error.message : error));
