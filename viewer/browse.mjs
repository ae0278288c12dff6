// Open the viewer in headless Chromium (Debian's /usr/bin/chromium, driven by playwright-core), wait
// until the tileset is loaded, take a screenshot, optionally click a building and measure frames per
// second. Prints one JSON object (with the bytes and requests of the tileset's files until the first view was
// loaded: firstViewBytes, firstViewRequests). Used by the tests and benchmarks/bench_3dtiles.py.
// Usage: node browse.mjs URL SCREENSHOT.png [--click] [--fps SECONDS] [--timeout SECONDS] [--size WxH] [--no-facades]
// (--no-facades: the viewer's "Generated facades" switch turned off before the screenshot)
import { chromium } from "playwright-core";

const [url, screenshot, ...rest] = process.argv.slice(2);
const option = (name, fallback) => {
  const i = rest.indexOf(name);
  return i >= 0 ? rest[i + 1] : fallback;
};
const [width, height] = option("--size", "1280x800").split("x").map(Number);
const timeout = Number(option("--timeout", "180")) * 1000;
const result = { url, loaded: false, state: null, loadSeconds: null, navigationSeconds: null, consoleErrors: [],
                 pageErrors: [], httpErrors: [], failedRequests: [], externalRequests: [], webgl: null, info: null, fps: null };

const browser = await chromium.launch({
  executablePath: process.env.CHROMIUM || "/usr/bin/chromium",
  // WebGL without a GPU: ANGLE on SwiftShader (software), which Chromium enables only when asked.
  args: ["--headless=new", "--no-sandbox", "--no-first-run", "--disable-background-networking",
         "--disable-component-update", "--disable-sync", "--disable-gpu", "--use-angle=swiftshader",
         "--enable-unsafe-swiftshader", "--ignore-gpu-blocklist"],
});
try {
  const page = await browser.newPage({ viewport: { width, height } });
  page.on("console", (message) => { if (message.type() === "error") result.consoleErrors.push(message.text()); });
  page.on("pageerror", (error) => result.pageErrors.push(String(error)));
  let tilesetBytes = 0;  // bytes of the tileset's files (JSON, glTF, images) received so far, and their number
  let tilesetRequests = 0;
  page.on("response", (response) => {
    if (response.status() >= 400) result.httpErrors.push(`${response.status()} ${response.url()}`);
    if (new URL(response.url()).pathname.includes("/3dtiles/")) {
      tilesetRequests += 1;
      tilesetBytes += Number(response.headers()["content-length"] || 0);
    }
  });
  page.on("requestfailed", (request) => result.failedRequests.push(`${request.url()} ${request.failure()?.errorText}`));
  page.on("request", (request) => {
    const host = new URL(request.url()).hostname;
    if (!["127.0.0.1", "localhost"].includes(host) && !request.url().startsWith("data:")
        && !request.url().startsWith("blob:")) result.externalRequests.push(request.url());
  });
  const started = Date.now();
  await page.goto(url, { waitUntil: "load" });
  result.webgl = await page.evaluate(() => {
    const gl = document.createElement("canvas").getContext("webgl2");
    return gl ? gl.getParameter(gl.RENDERER) : null;
  });
  await page.waitForFunction(() => window.witViewer && window.witViewer.state !== "loading", null,
                             { timeout, polling: 200 });
  result.navigationSeconds = (Date.now() - started) / 1000;
  Object.assign(result, { firstViewBytes: tilesetBytes, firstViewRequests: tilesetRequests });
  Object.assign(result, await page.evaluate(() => ({ state: witViewer.state, loadSeconds: witViewer.loadSeconds, loadedTiles: witViewer.loadedTiles,
                                                     viewerErrors: witViewer.errors })));
  result.loaded = result.state === "ready";
  if (rest.includes("--no-facades")) {
    await page.click("#facades-on");  // a real click on the switch
    result.facadesShown = await page.evaluate(() => document.getElementById("facades-on").checked);
  }
  await page.waitForTimeout(500);  // a few frames after the last tile
  await page.screenshot({ path: screenshot, timeout });  // software WebGL on a loaded machine: slow frames
  if (rest.includes("--fps")) {
    result.fps = await page.evaluate((seconds) => witViewer.measureFps(seconds), Number(option("--fps", "5")));
  }
  if (rest.includes("--click") && result.loaded) {
    const hits = await page.evaluate(() => witViewer.buildingPixels(40));
    result.buildingPixels = hits.length;
    if (hits.length) {
      const named = hits.filter((hit) => hit[2]);  // prefer a building with a (Korean) name
      const [x, y] = (named.length ? named : hits)[0];
      await page.mouse.click(x, y);
      await page.waitForSelector("#info:not([hidden])", { timeout: Math.min(timeout, 120000) });
      result.info = await page.evaluate(() => ({
        title: document.getElementById("info-title").textContent,
        rows: Object.fromEntries([...document.querySelectorAll("#info-table tr")].map(
          (row) => [row.cells[0].textContent, row.cells[1].textContent])),
      }));
      await page.screenshot({ path: screenshot.replace(/\.png$/, "-click.png"), timeout });
    }
  }
} catch (error) {
  result.error = String(error);
} finally {
  await browser.close();
}
console.log(JSON.stringify(result, null, 1));
