// Drive the player in headless Chromium (software WebGL): screenshots at given times, optionally the frame time.
//   node shoot.mjs URL [--shot SECONDS:OUT.png]... [--size 480x480] [--measure FRAMES]
// URL is the player page with ?src=…; each shot loads it paused at SECONDS and waits for window.playerReady.
// Prints one JSON line: {"shots": [...]}, with --measure also "frameTime" (see player.js's measure), "renderer"
// and "duration" (the animation's, seconds).
// CHROMIUM names the browser (default /usr/bin/chromium, the Debian package).
import { chromium } from "playwright-core";

const SOFTWARE_WEBGL = ["--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--ignore-gpu-blocklist"];
const TIMEOUT_MS = 60000;

function parse(argv) {
  const options = { url: null, shots: [], width: 480, height: 480, measure: 0 };
  for (let i = 0; i < argv.length; i++) {
    const arg = argv[i];
    if (arg === "--shot") {
      const [seconds, ...out] = argv[++i].split(":");
      options.shots.push({ seconds: Number(seconds), out: out.join(":") });
    } else if (arg === "--size") {
      [options.width, options.height] = argv[++i].split("x").map(Number);
    } else if (arg === "--measure") {
      options.measure = Number(argv[++i]);
    } else if (!options.url && !arg.startsWith("--")) {
      options.url = arg;
    } else {
      throw new Error(`unknown argument ${arg}`);
    }
  }
  if (!options.url) throw new Error("usage: node shoot.mjs URL [--shot SECONDS:OUT.png]... [--size WxH] [--measure N]");
  return options;
}

async function open(browser, options, query) {
  const page = await browser.newPage({ viewport: { width: options.width, height: options.height } });
  const errors = [];
  page.on("pageerror", (error) => errors.push(error.message));
  page.on("response", (response) => response.status() >= 400 && errors.push(`${response.status()} ${response.url()}`));
  const url = new URL(options.url);
  for (const [name, value] of Object.entries(query)) url.searchParams.set(name, value);
  await page.goto(url.href);
  await page.waitForFunction(() => window.playerReady || window.playerError, null, { timeout: TIMEOUT_MS });
  const failure = await page.evaluate(() => window.playerError);
  if (failure || errors.length) throw new Error(`${url.href}: ${failure ?? errors.join("; ")}`);
  return page;
}

const options = parse(process.argv.slice(2));
const browser = await chromium.launch({
  executablePath: process.env.CHROMIUM || "/usr/bin/chromium",
  args: SOFTWARE_WEBGL,
});
try {
  const report = { shots: [] };
  for (const shot of options.shots) {
    const page = await open(browser, options, { t: shot.seconds, paused: 1 });
    await page.screenshot({ path: shot.out });
    report.shots.push({ ...shot, renderer: await page.evaluate(rendererName) });
    await page.close();
  }
  if (options.measure > 0) {
    const page = await open(browser, options, { paused: 1 });
    report.frameTime = await page.evaluate((frames) => window.player.measure(frames), options.measure);
    report.renderer = await page.evaluate(rendererName);
    report.duration = await page.evaluate(() => window.player.duration);
    await page.close();
  }
  console.log(JSON.stringify(report));
} finally {
  await browser.close();
}

// The WebGL renderer's name, to show that the software path (SwiftShader) drew the frames.
function rendererName() {
  const gl = document.querySelector("canvas").getContext("webgl2");
  const info = gl.getExtension("WEBGL_debug_renderer_info");
  return info ? gl.getParameter(info.UNMASKED_RENDERER_WEBGL) : gl.getParameter(gl.RENDERER);
}
