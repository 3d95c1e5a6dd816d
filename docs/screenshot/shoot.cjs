// Screenshot of `planner view` in a real viewer: headless Chromium opens a locally served
// Lichtblick web build with the Foxglove WebSocket data source and our layout
// (planner/view/layout.json, handed to Lichtblick's `layoutUrl` URL parameter), waits, and
// saves a PNG. Needs `playwright-core` (npm) and a Chromium; nothing here is part of the
// Rust build or tests. See README.md next to this file.
//
// Environment (defaults in brackets):
//   LICHTBLICK_URL  the served Lichtblick web build            [http://127.0.0.1:8080/]
//   WS_URL          the running `planner view`                   [ws://127.0.0.1:8765]
//   LAYOUT          layout file to load                          [planner/view/layout.json]
//   OUT             PNG to write                                 [view-screenshot.png]
//   WAIT_S          seconds to let the roadmap grow before shooting [15]
//   WIDTH, HEIGHT   viewport                                     [1600, 900]
//   CHROMIUM        browser binary                               [/usr/bin/chromium]
//   GL              extra GL flags, space separated   [--use-angle=swiftshader --enable-unsafe-swiftshader]
//   MCAP            instead of WS_URL: open this recording (`planner view --record`) through
//                   Lichtblick's local-file input and play it for WAIT_S seconds
//   VARIANT         `no-roadmap`: the same layout with the roadmap topics hidden and the camera
//                   at 0.7 m, so the object, proxy, forces and paths are not behind the nodes

"use strict";
const fs = require("fs");
const path = require("path");
const os = require("os");
const { chromium } = require("playwright-core");

const env = (k, d) => (process.env[k] && process.env[k] !== "" ? process.env[k] : d);
const base = env("LICHTBLICK_URL", "http://127.0.0.1:8080/");
const wsUrl = env("WS_URL", "ws://127.0.0.1:8765");
const layoutFile = env("LAYOUT", path.join(__dirname, "..", "..", "planner", "view", "layout.json"));
const out = env("OUT", "view-screenshot.png");
const waitS = Number(env("WAIT_S", "15"));
const width = Number(env("WIDTH", "1600"));
const height = Number(env("HEIGHT", "900"));
const gl = env("GL", "--use-angle=swiftshader --enable-unsafe-swiftshader").split(/\s+/).filter(Boolean);

(async () => {
  let layout = fs.readFileSync(layoutFile, "utf8");
  const parsed = JSON.parse(layout); // fail early on a broken file
  if (env("VARIANT", "") === "no-roadmap") {
    const panel = parsed.configById["3D!hrrtc-view"];
    panel.topics["/view/roadmap/nodes"].visible = false;
    panel.topics["/view/roadmap/edges"].visible = false;
    panel.cameraState.distance = 0.7;
    layout = JSON.stringify(parsed);
  }
  const profile = fs.mkdtempSync(path.join(os.tmpdir(), "shot-profile-"));
  const browser = await chromium.launchPersistentContext(profile, {
    executablePath: env("CHROMIUM", "/usr/bin/chromium"),
    headless: true,
    viewport: { width, height },
    deviceScaleFactor: 1,
    args: [
      "--no-sandbox",
      "--disable-gpu",
      "--disable-quic",
      "--no-first-run",
      "--disable-background-networking",
      "--disable-component-update",
      "--disable-sync",
      ...gl,
    ],
  });
  const page = browser.pages()[0] ?? (await browser.newPage());
  page.on("console", (m) => {
    if (m.type() === "error" || m.type() === "warning") {
      console.log(`[browser ${m.type()}] ${m.text().slice(0, 300)}`);
    }
  });
  page.on("pageerror", (e) => console.log(`[page error] ${String(e).slice(0, 300)}`));

  // Serve the layout from the viewer's own origin (Lichtblick fetches `layoutUrl`).
  const layoutUrl = new URL("hrrtc-view-layout.json", base).toString();
  await page.route(layoutUrl, (route) =>
    route.fulfill({ status: 200, contentType: "application/json", body: layout }),
  );

  const mcap = env("MCAP", "");
  const url = new URL(base);
  if (mcap === "") {
    url.searchParams.set("ds", "foxglove-websocket");
    url.searchParams.set("ds.url", wsUrl);
  }
  url.searchParams.set("layoutUrl", layoutUrl);
  console.log(`opening ${url}`);
  await page.goto(url.toString(), { waitUntil: "load" });
  if (mcap !== "") {
    // Lichtblick's hidden file input behind "Open local file" and drag-and-drop.
    const input = page.locator("input[data-puppeteer-file-upload]");
    await input.waitFor({ state: "attached", timeout: 60000 });
    await page.waitForTimeout(3000); // let the layout from layoutUrl arrive first
    await input.setInputFiles(mcap);
    console.log(`opened ${mcap}`);
    await page.waitForTimeout(5000);
    await page.keyboard.press("Space"); // play
  }

  const t0 = Date.now();
  while (Date.now() - t0 < waitS * 1000) {
    await page.waitForTimeout(1000);
    // Close first-run popups (welcome / "new version" notes) if any appear.
    await page.keyboard.press("Escape").catch(() => {});
  }
  // The left sidebar (panel settings, topics, alerts) takes a fifth of the width: show the
  // alerts in a side shot when DEBUG_DIR is set, then close it for the picture.
  const alertsTab = page.getByRole("tab", { name: /Alerts/ });
  if (process.env.DEBUG_DIR && (await alertsTab.count()) > 0) {
    await alertsTab.first().click();
    await page.waitForTimeout(500);
    await page.screenshot({ path: path.join(process.env.DEBUG_DIR, "alerts.png") });
  }
  if (env("SIDEBAR", "close") === "close") {
    const toggle = page.getByTestId("left-sidebar-button");
    if ((await page.getByRole("tab", { name: /Topics/ }).count()) > 0 && (await toggle.count()) > 0) {
      await toggle.first().click();
    }
  }
  await page.mouse.move(width - 2, height - 2); // no hover tooltip over the panels
  await page.waitForTimeout(500);
  await page.screenshot({ path: out });
  console.log(`wrote ${out}`);
  await browser.close();
  fs.rmSync(profile, { recursive: true, force: true });
})().catch((e) => {
  console.error(e);
  process.exit(1);
});
