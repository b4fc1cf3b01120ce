// The screenshot of docs/viewer.md: the viewer at URL in headless Chromium (SwiftShader), the
// newest date coloured by the change of the canopy since the first, one site's growth curve open.
//   NODE_PATH=<build>/src/crop4d/viewer/npm/node_modules node viewer/test/screenshot.cjs URL OUT.png
const { chromium } = require('playwright-core');

(async () => {
  const [url, out] = process.argv.slice(2);
  const browser = await chromium.launch({ executablePath: process.env.CROP4D_CHROMIUM || '/usr/bin/chromium',
    headless: true, args: ['--no-sandbox', '--use-gl=angle', '--use-angle=swiftshader',
      '--enable-unsafe-swiftshader', '--disable-background-networking', '--disable-component-update',
      '--disable-sync', '--no-first-run'] });
  const page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
  await page.goto(url + '?color=change', { waitUntil: 'load' });
  await page.waitForFunction(() => { const s = window.crop4dViewer && window.crop4dViewer.state;
    return s && s.ready && s.firstFrameMs !== null; }, null, { timeout: 60000 });
  await page.evaluate(() => { const v = window.crop4dViewer; v.setCompare(0); v.showSite(v.sites()[4]); });
  let loaded = -1;
  for (;;) {  // until the tiles of this view have arrived
    await page.waitForTimeout(2000);
    const n = await page.evaluate(() => window.crop4dViewer.state.loadedNodes);
    if (n === loaded) break;
    loaded = n;
  }
  await page.screenshot({ path: out });
  await browser.close();
})().catch((e) => { console.error(e); process.exit(1); });
