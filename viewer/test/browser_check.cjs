// Loads the crop4d viewer at URL in headless Chromium (playwright-core from viewer's lock file,
// the system's /usr/bin/chromium, software WebGL through SwiftShader) and checks it: no console
// error, no failed request, every date in the page's state, the newest date shown first, the
// time slider switching dates, two dates overlaid, change colouring, measuring. Exits 0 when all
// hold, 1 with what failed otherwise (src/crop4d/viewer/viewer_browser_test.cc runs it).
//   node browser_check.cjs URL EXPECTED_DATES_JSON [SCREENSHOT.png]
// Environment: CROP4D_CHROMIUM (default /usr/bin/chromium).
const { chromium } = require('playwright-core');

const CHROMIUM_ARGS = [
  '--no-sandbox', '--use-gl=angle', '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
  '--disable-background-networking', '--disable-component-update', '--disable-sync',
  '--no-first-run',
];

async function main() {
  const [url, datesJson, screenshot] = process.argv.slice(2);
  const expectedDates = JSON.parse(datesJson || '[]');
  const executablePath = process.env.CROP4D_CHROMIUM || '/usr/bin/chromium';
  const browser = await chromium.launch({ executablePath, headless: true, args: CHROMIUM_ARGS });
  const problems = [];
  try {
    const page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
    page.on('console', (msg) => { if (msg.type() === 'error') problems.push('console error: ' + msg.text()); });
    page.on('pageerror', (err) => problems.push('page error: ' + err.message));
    page.on('requestfailed', (req) => problems.push('request failed: ' + req.url()));
    page.on('response', (res) => { if (res.status() >= 400) problems.push(`HTTP ${res.status()}: ${res.url()}`); });
    await page.goto(url, { waitUntil: 'load', timeout: 30000 });
    const loaded = (index) => page.waitForFunction((i) => {
      const s = window.crop4dViewer && window.crop4dViewer.state;
      return s && (s.error || (s.ready && s.dateIndex === i && s.visiblePoints > 0 && s.firstFrameMs !== null));
    }, index, { timeout: 30000 });
    await loaded(expectedDates.length - 1);
    const state = () => page.evaluate(() => JSON.parse(JSON.stringify(window.crop4dViewer.state)));
    let s = await state();
    const expect = (ok, what) => { if (!ok) problems.push(what); };
    expect(!s.error, 'viewer error: ' + s.error);
    expect(JSON.stringify(s.dates) === JSON.stringify(expectedDates),
      `dates ${JSON.stringify(s.dates)}, expected ${JSON.stringify(expectedDates)}`);
    expect(s.visibleSessions.length === 1 && s.visibleSessions[0] === s.sessions[s.sessions.length - 1],
      'the newest session is not the one shown first: ' + JSON.stringify(s.visibleSessions));
    // The slider, as a user moves it: the first date, its cloud alone.
    await page.$eval('#date', (el) => { el.value = '0'; el.dispatchEvent(new Event('input', { bubbles: true })); });
    await loaded(0);
    s = await state();
    expect(s.dateIndex === 0 && s.visibleSessions.length === 1 && s.visibleSessions[0] === s.sessions[0],
      'the slider did not switch to the first date: ' + JSON.stringify(s.visibleSessions));
    expect(await page.textContent('#date-label') === expectedDates[0], 'the date label does not follow the slider');
    // Two dates overlaid, then coloured by change.
    await page.$eval('#date', (el) => { el.value = String(el.max); el.dispatchEvent(new Event('input', { bubbles: true })); });
    await page.selectOption('#mode', 'two');
    await page.$eval('#compare', (el) => { el.value = '0'; el.dispatchEvent(new Event('input', { bubbles: true })); });
    s = await state();
    expect(s.mode === 'two' && s.visibleSessions.length === Math.min(2, expectedDates.length),
      'two dates are not overlaid: ' + JSON.stringify(s.visibleSessions));
    await page.selectOption('#color', 'change');
    const frames = s.frames;
    await page.waitForFunction((f) => window.crop4dViewer.state.frames > f + 3, frames, { timeout: 20000 });
    s = await state();
    expect(s.colorBy === 'change', 'colour by change not taken');
    // Measuring between two points: distance, horizontal distance, height difference.
    const m = await page.evaluate(() => window.crop4dViewer.measureBetween([0, 0, 0], [3, 4, 1]));
    await page.evaluate(() => { window.crop4dViewer.state.measure = null; });
    expect(Math.abs(m.distance - Math.sqrt(26)) < 1e-9 && Math.abs(m.horizontal - 5) < 1e-9 &&
      Math.abs(m.height - 1) < 1e-9, 'measuring: ' + JSON.stringify(m));
    expect((await page.textContent('#panel')).includes('5.099 m'), 'the measurement is not shown');
    // Measuring as a user does: the tool, then two clicks on the field (terrain shown, so both
    // clicks hit something).
    await page.check('#show-terrain');
    await page.click('#measure');
    const box = await page.locator('#view canvas').boundingBox();
    await page.mouse.click(box.x + box.width * 0.45, box.y + box.height * 0.55);
    await page.mouse.click(box.x + box.width * 0.55, box.y + box.height * 0.6);
    const clicked = await page.evaluate(() => window.crop4dViewer.state.measure);
    expect(clicked && clicked.distance > 0.05 && clicked.distance < 50 &&
      Math.abs(Math.hypot(clicked.b[0] - clicked.a[0], clicked.b[1] - clicked.a[1], clicked.b[2] - clicked.a[2]) - clicked.distance) < 1e-9,
      'two clicks did not measure: ' + JSON.stringify(clicked));
    await page.click('#measure');
    // A site's growth curve (what a click on its marker opens).
    const curve = await page.evaluate(() => {
      const site = window.crop4dViewer.sites && window.crop4dViewer.sites()[0];
      if (!site) return null;
      window.crop4dViewer.showSite(site);
      return document.querySelectorAll('#panel svg circle').length;
    });
    expect(curve > 0, 'no site, or its panel has no growth curve');
    if (screenshot) await page.screenshot({ path: screenshot });
    console.log(JSON.stringify({ dates: s.dates, frames: s.frames, loadedNodes: s.loadedNodes,
      visiblePoints: s.visiblePoints, firstFrameMs: s.firstFrameMs }));
  } finally {
    await browser.close();
  }
  if (problems.length) {
    console.error('viewer check failed:\n  ' + problems.join('\n  '));
    process.exit(1);
  }
  console.log('viewer check ok');
}

main().catch((err) => { console.error('viewer check failed: ' + (err && err.stack || err)); process.exit(1); });
