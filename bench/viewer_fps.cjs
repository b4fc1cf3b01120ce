// The 4D viewer's speed in headless Chromium with software rendering (SwiftShader): time until
// the first frame with points, and frames per second while the camera orbits, for one session
// at several point budgets and refinement thresholds (bench/RESULTS.md, "4D viewer"). Prints a
// Markdown table. A configuration is BUDGET:REFINE_PIXELS; REFINE_PIXELS 0 refines every node,
// so the whole session is drawn when it fits the budget.
//   node bench/viewer_fps.cjs URL DATE [CONFIGS=1000000:80,3000000:80,1000000:0,4000000:0]
//                                      [SECONDS=10] [SCREENSHOT]
// NODE_PATH must hold the build's viewer packages (bench/viewer_fps.sh sets it).
const { chromium } = require('playwright-core');

const ARGS = ['--no-sandbox', '--use-gl=angle', '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
  '--disable-background-networking', '--disable-component-update', '--disable-sync', '--no-first-run'];

async function run(browser, url, seconds, screenshot) {
  const page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
  const errors = [];
  page.on('pageerror', (e) => errors.push(e.message));
  page.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
  const t0 = Date.now();
  await page.goto(url, { waitUntil: 'load' });
  await page.waitForFunction(() => { const s = window.crop4dViewer && window.crop4dViewer.state;
    return s && (s.error || s.firstFrameMs !== null); }, null, { timeout: 120000 });
  const first = await page.evaluate(() => window.crop4dViewer.state.firstFrameMs);
  // Until every tile this view asks for has arrived (the loaded count stands still for 2 s).
  let loaded = -1;
  for (;;) {
    await page.waitForTimeout(2000);
    const n = await page.evaluate(() => window.crop4dViewer.state.loadedNodes);
    if (n === loaded) break;
    loaded = n;
  }
  const settled = (Date.now() - t0) / 1000 - 2;
  const result = await page.evaluate(async (sec) => {
    const v = window.crop4dViewer;
    const f0 = v.state.frames, t = performance.now();
    let maxShown = 0;
    while (performance.now() - t < sec * 1000) {
      v.rotate(0.02);
      maxShown = Math.max(maxShown, v.state.visiblePoints);
      await new Promise((r) => requestAnimationFrame(r));
    }
    return { fps: (v.state.frames - f0) / ((performance.now() - t) / 1000), shown: maxShown,
      tiles: v.state.loadedNodes, error: v.state.error };
  }, seconds);
  if (screenshot) await page.screenshot({ path: screenshot });
  await page.close();
  return { first, settled, ...result, errors };
}

async function main() {
  const [url, date, budgetsArg, secondsArg, screenshot] = process.argv.slice(2);
  const configs = (budgetsArg || '1000000:80,3000000:80,1000000:0,4000000:0').split(',')
    .map((c) => c.split(':').map(Number));
  const seconds = Number(secondsArg || 10);
  const browser = await chromium.launch({ executablePath: process.env.CROP4D_CHROMIUM || '/usr/bin/chromium',
    headless: true, args: ARGS });
  console.log(`| point budget | refine above [px] | points shown (max while orbiting) | first frame [s] | all tiles of the view [s] | frames per second (orbiting, ${seconds} s) |`);
  console.log('|---:|---:|---:|---:|---:|---:|');
  for (const [budget, refine] of configs) {
    const r = await run(browser, `${url}?date=${date}&budget=${budget}&refine=${refine}`, seconds,
      screenshot && budget === configs[0][0] && refine === configs[0][1] ? screenshot : null);
    if (r.error || r.errors.length) console.error('errors:', r.error, r.errors);
    console.log(`| ${budget.toLocaleString('en')} | ${refine} | ${r.shown.toLocaleString('en')} | ${(r.first / 1000).toFixed(2)} | ${r.settled.toFixed(1)} | ${r.fps.toFixed(1)} |`);
  }
  await browser.close();
}

main().catch((e) => { console.error(e); process.exit(1); });
