// A PNG of the Rerun web viewer with no display: headless Chromium (software WebGL) on the
// viewer that `llmland view --web` serves on loopback. Made docs/img/rerun_landing.png:
//   apt-get install chromium && npm install playwright-core     (in some scratch folder)
//   .venv/bin/llmland view --web runs/landing.rrd &
//   node scripts/rerun_screenshot.mjs 'http://127.0.0.1:9090/?url=rerun%2Bhttp://127.0.0.1:9876/proxy' \
//        docs/img/rerun_landing.png 40000 0.75
// Arguments: viewer URL, output PNG, ms to wait for the recording to load, and where on the
// timeline to stop (0 start … 1 end; the time bar's ends are measured at a 1600×960 viewport).
import { chromium } from 'playwright-core';

const [url, out, waitMs, frac] = [process.argv[2], process.argv[3], Number(process.argv[4] || 30000),
                                  Number(process.argv[5] || -1)];
const VIEWPORT = { width: 1600, height: 960 };
const TIME_BAR = { x0: 295, x1: 1388, y: 946 };
const FOCUS = { x: 1400, y: 540 };  // inside the caption text: gives the page the keyboard, selects nothing

const browser = await chromium.launch({
  executablePath: process.env.CHROMIUM || '/usr/bin/chromium', headless: true,
  args: ['--no-sandbox', '--disable-gpu', '--no-first-run', '--disable-background-networking',
         '--disable-component-update', '--disable-sync', '--enable-unsafe-swiftshader', '--use-angle=swiftshader'],
});
const page = await browser.newPage({ viewport: VIEWPORT });
await page.goto(url);
await page.waitForTimeout(waitMs);
await page.mouse.click(FOCUS.x, FOCUS.y);
await page.keyboard.press('Space');  // pause the playback the blueprint starts
await page.waitForTimeout(1000);
if (frac >= 0) {
  await page.mouse.click(TIME_BAR.x0 + frac * (TIME_BAR.x1 - TIME_BAR.x0), TIME_BAR.y);
  await page.waitForTimeout(4000);
}
await page.screenshot({ path: out });
await browser.close();
