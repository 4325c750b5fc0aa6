// Browser tests of the page build (dist/, `.ci/build-web`) in headless Chromium, driven by playwright-core.
//
// Runs the page twice:
//   - "webgpu": with the WebGPU flags (SwiftShader Vulkan). status() must report WebGPU and the
//     self-test's GPU result must match its CPU result.
//   - "cpu": without them. eframe falls back to WebGL2, status() must report the CPU path, and
//     the same computation must succeed on the CPU with the same bits.
// Both runs: no page errors, terrain shown, and the CPU checksum equal to the native build's
// (`$STRAHLER_BIN info --check --json`), i.e. same problem, same bits, in the browser and natively.
//
// Usage: node tests/browser.mjs [DIST_DIR]   (env: CHROMIUM, STRAHLER_BIN, TEST_OUTPUT)

import { execFileSync } from 'node:child_process';
import { existsSync, mkdirSync, readFileSync, rmSync, writeFileSync } from 'node:fs';
import { join, resolve } from 'node:path';
import { chromium } from 'playwright-core';
import { COMMON_FLAGS, WEBGPU_FLAGS, decodePng, serve } from './harness.mjs';

const here = new URL('.', import.meta.url).pathname;
const dist = resolve(process.argv[2] ?? join(here, '..', '..', 'dist'));
const chromiumPath = process.env.CHROMIUM ?? '/usr/bin/chromium';
const output = resolve(process.env.TEST_OUTPUT ?? join(here, '..', 'test-output'));
mkdirSync(output, { recursive: true });

// The first terrain's checksum in each mode (the default scene): the run without workers
// compares with it.
const firstChecksums = {};
let passed = 0;
let failed = 0;
function check(name, condition, detail = '') {
  if (condition) { passed += 1; console.log(`  ok   ${name}`); }
  else { failed += 1; console.log(`  FAIL ${name} ${detail}`); }
}

function nativeChecksum() {
  const bin = process.env.STRAHLER_BIN;
  if (!bin) return null;
  const report = JSON.parse(execFileSync(bin, ['info', '--check', '--json'], { encoding: 'utf8' }));
  return report.check.cpu.checksum;
}

// Runs in the page before its scripts: each terrain that reaches the map until the page is
// first idle (its pass and width), so the first terrain's passes can be checked.
function watchFirstTerrains() {
  window.__firstTerrains = [];
  let last = null;
  const poll = () => {
    const s = window.strahler?.status();
    if (s?.lastRun && s.lastRun.checksum !== last) {
      last = s.lastRun.checksum;
      window.__firstTerrains.push({ pass: s.terrain.pass, width: s.terrain.width });
    }
    if (!(s?.lastRun && s.job === null)) setTimeout(poll, 5);
  };
  poll();
}

// Runs in the page: applies an edit (the body of `edit`, a function of window.strahler) and
// returns each terrain that reaches the map until the page is idle again: its pass, width and
// the milliseconds since the edit.
async function passesOfEdit(editSource) {
  const edit = new Function('strahler', editSource);
  const seen = [];
  let last = window.strahler.status().lastRun?.checksum;
  const start = performance.now();
  edit(window.strahler);
  await new Promise((done) => {
    const poll = () => {
      const s = window.strahler.status();
      if (s.lastRun && s.lastRun.checksum !== last) {
        last = s.lastRun.checksum;
        seen.push({ pass: s.terrain.pass, width: s.terrain.width, ms: performance.now() - start });
      }
      if (seen.length > 0 && s.job === null) done();
      else setTimeout(poll, 5);
    };
    poll();
  });
  return seen;
}

// The Web Worker's threads as the page reports them: in a cross-origin isolated page the
// threaded build's pool of the machine's cores (at most 8; 2 on this machine), else one
// thread, saying why. Where `.ci/build-web` could not make the threaded build it wrote why
// in dist/threads/MISSING, and the page must say the build did not load.
async function checkThreads(page, mode) {
  const { status, cores, isolated } = await page.evaluate(() => ({
    status: window.strahler.status(),
    cores: navigator.hardwareConcurrency,
    isolated: window.crossOriginIsolated,
  }));
  const stages = 'the diffusion and the erosion run in a Web Worker';
  const missing = join(dist, 'threads', 'MISSING');
  check(`${mode}: the page is ${mode === 'cpu' ? '' : 'not '}cross-origin isolated`,
    isolated === (mode === 'cpu'), String(isolated));
  if (mode !== 'cpu') {
    check('without cross-origin isolation the worker runs one thread and says why',
      status.threads === 1
        && status.worker === `${stages} (one thread: the page is not cross-origin isolated (its server sends no COOP and COEP headers))`,
      `${status.threads}: ${status.worker}`);
  } else if (existsSync(missing)) {
    console.log(`  NOTE: no threaded build (${readFileSync(missing, 'utf8').trim()}): the worker runs one thread`);
    check('without the threaded build the worker runs one thread and says its build did not load',
      status.threads === 1 && status.worker.startsWith(`${stages} (one thread: the threaded build did not load`),
      `${status.threads}: ${status.worker}`);
  } else {
    const want = Math.min(cores, 8);
    check(`the cross-origin isolated page computes on ${want} threads (its cores)`,
      want < 2 || (status.threads === want && status.worker === `${stages} (${want} threads)`),
      `${status.threads}: ${status.worker}`);
  }
}

async function runMode(url, mode, expectedChecksum) {
  console.log(`browser (${mode}):`);
  const browser = await chromium.launch({
    executablePath: chromiumPath,
    // playwright gives every launch a fresh, empty profile of its own.
    args: [...COMMON_FLAGS, ...(mode === 'webgpu' ? WEBGPU_FLAGS : [])],
  });
  const pageErrors = [];
  const consoleErrors = [];
  const consoleWarnings = [];
  try {
    const page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
    page.on('pageerror', (err) => pageErrors.push(String(err)));
    page.on('console', (msg) => {
      if (msg.type() === 'error') consoleErrors.push(msg.text());
      if (msg.type() === 'warning') consoleWarnings.push(msg.text());
    });
    await page.addInitScript(watchFirstTerrains);
    await page.goto(url);
    await page.waitForFunction(() => window.strahler?.status().ready === true, null, { timeout: 90_000 });
    const status = await page.evaluate(() => window.strahler.status());
    console.log(`  status: ${status.computePath} (version ${status.version})`);
    check('status() reports the version', typeof status.version === 'string' && status.version.length > 0);
    if (mode === 'webgpu') {
      check('status() reports WebGPU', status.compute === 'webgpu' && status.computePath === 'GPU: WebGPU',
        JSON.stringify(status));
    } else {
      check('status() reports the CPU fallback', status.compute === 'cpu'
        && status.computePath === 'CPU (this browser has no WebGPU)', JSON.stringify(status));
    }

    // The first fill runs by itself: terrain appears without any click.
    await page.waitForFunction(() => window.strahler.status().lastRun !== null, null, { timeout: 90_000 });
    // The first terrain comes in two passes: a coarse one at once, then the scene's own size.
    await page.waitForFunction(() => window.strahler.status().job === null, null, { timeout: 120_000 });
    const firsts = await page.evaluate(() => window.__firstTerrains);
    const settledTerrain = (await page.evaluate(() => window.strahler.status())).terrain;
    check('the first terrain shows a coarse 128^2 pass, then the scene\'s 512^2',
      firsts[0]?.pass === 'coarse' && firsts[0]?.width === 128
        && settledTerrain.pass === 'full' && settledTerrain.width === 512,
      `${JSON.stringify(firsts)} then ${JSON.stringify(settledTerrain)}`);
    const run = (await page.evaluate(() => window.strahler.status())).lastRun;
    check('first terrain is shown', run.max - run.min > 100, JSON.stringify(run));
    check('first terrain is a converged multigrid fill', run.method === 'multigrid' && run.converged,
      JSON.stringify(run));
    // SwiftShader is a software rasteriser: "Compute on: auto" computes on the CPU beside it
    // (every stage is slower on it), as the command line does beside lavapipe.
    check('first terrain ran on the CPU (auto beside a software rasteriser, or no WebGPU)',
      run.backend === 'cpu', run.backend);
    // Issue 35: the diffusion and the erosion (most of a CPU run) run in the page's Web Worker,
    // on every core where the page is cross-origin isolated (the CPU mode's server sends the
    // headers), on one thread where it is not (the WebGPU mode's).
    await checkThreads(page, mode);
    firstChecksums[mode] = run.checksum;
    if (mode === 'webgpu') {
      // "Compute on: gpu" runs every stage on SwiftShader (erosion too, tens of seconds a
      // run here): once, then back to auto; the 3D view's GPU maps ask for it again below.
      let refused = null;
      try { await page.evaluate(() => window.strahler.setCompute('tpu')); } catch (e) { refused = String(e); }
      check('setCompute() names a choice it does not know', refused !== null && refused.includes('tpu'),
        String(refused));
      await page.evaluate(() => window.strahler.setCompute('gpu'));
      const onGpu = (await page.evaluate(() => window.strahler.status())).lastRun;
      check('setCompute("gpu") recomputes the terrain on the GPU',
        onGpu.backend === 'gpu' && onGpu.converged && onGpu.max - onGpu.min > 100, JSON.stringify(onGpu));
      await page.evaluate(() => window.strahler.setCompute('auto'));
      const back = (await page.evaluate(() => window.strahler.status())).lastRun;
      check('setCompute("auto") goes back to the CPU beside SwiftShader, with the same bits as before',
        back.backend === 'cpu' && back.checksum === run.checksum, `${back.checksum} != ${run.checksum}`);
    }

    const test = await page.evaluate(() => window.strahler.selfTest());
    console.log(`  selfTest: cpu ${test.cpu.millis.toFixed(0)} ms` +
      (test.gpu ? `, gpu ${test.gpu.millis.toFixed(0)} ms, rel diff ${test.relative_diff}` : ''));
    check('CPU computation succeeds', /^[0-9a-f]{16}$/.test(test.cpu.checksum) && test.cpu.max > 600);
    check('multigrid converges on the CPU', test.multigrid.cpu.converged === true,
      JSON.stringify(test.multigrid.cpu));
    if (mode === 'webgpu') {
      check('GPU computation ran', test.gpu !== null);
      check('GPU result matches CPU', test.relative_diff !== null && test.relative_diff <= 1e-5,
        String(test.relative_diff));
      check('GPU multigrid converges and matches CPU multigrid', test.multigrid.gpu?.converged === true
        && test.multigrid.relative_diff <= 1e-4, JSON.stringify(test.multigrid));
    } else {
      check('no GPU computation on the fallback', test.gpu === null);
    }
    if (expectedChecksum) {
      check('CPU result has the same bits as the native build', test.cpu.checksum === expectedChecksum,
        `${test.cpu.checksum} != ${expectedChecksum}`);
    }
    // Scripted editing: scene(), addRiver(), loadScene() with a field-naming error.
    const scene = await page.evaluate(() => window.strahler.scene());
    if (mode === 'cpu' && process.env.STRAHLER_BIN) {
      // Same scene, same terrain: the page's CPU result has the command line's bits.
      const file = join(output, 'scene.json');
      const report = join(output, 'scene-report.json');
      writeFileSync(file, JSON.stringify(scene));
      execFileSync(process.env.STRAHLER_BIN, ['generate', file, '--backend', 'cpu', '--report', report]);
      const native = JSON.parse(readFileSync(report, 'utf8')).checksum;
      check('the page and the command line make the same terrain bits', run.checksum === native,
        `${run.checksum} != ${native}`);
    }
    check('scene() returns the document', scene.version === 1 && scene.rivers.length === 1,
      JSON.stringify(scene));
    // A world in tiles of this scene, planned in the page for `strahler build` (issue 37).
    const plan = await page.evaluate(() => window.strahler.worldPlan({ size: 16384, tile: 2048 }));
    check('worldPlan() plans a world in tiles of the scene',
      plan.size === 16384 && plan.tile === 2048 && plan.world === 2049 && plan.levels === 3
      && plan.refine === true
      && JSON.stringify(plan.scene) === JSON.stringify(scene), JSON.stringify(plan).slice(0, 200));
    const plain = await page.evaluate(() => window.strahler.worldPlan({ size: 16384, refine: false }));
    check('worldPlan({refine: false}) plans no refinement', plain.refine === false, JSON.stringify(plain.refine));
    const filledPlan = await page.evaluate(() => window.strahler.worldPlan({ size: 16384, fill: true }));
    check('worldPlan({fill: true}) plans the depressions filled (and not by default)',
      filledPlan.fill === true && plan.fill === false, `${filledPlan.fill}, ${plan.fill}`);
    const badPlan = await page.evaluate(() => {
      try { window.strahler.worldPlan({ size: 16384, tile: 100 }); return null; } catch (e) { return String(e.message); }
    });
    check('worldPlan() names a bad option', badPlan !== null && badPlan.includes('multiple of 16'), String(badPlan));
    if (mode === 'cpu' && process.env.STRAHLER_BIN) {
      const file = join(output, 'plan.json');
      writeFileSync(file, JSON.stringify(plan));
      // A world left by an earlier run of another scene would be refused (another build's plan).
      for (const world of ['world', 'filled-world']) {
        rmSync(join(output, world), { recursive: true, force: true });
      }
      const printed = execFileSync(process.env.STRAHLER_BIN,
        ['build', file, '--plan', '--out', join(output, 'world')]).toString();
      check('strahler build takes the page\'s plan', printed.includes('129 tasks in 3 stages'), printed);
      const filledFile = join(output, 'filled-plan.json');
      writeFileSync(filledFile, JSON.stringify(filledPlan));
      const filledPrinted = execFileSync(process.env.STRAHLER_BIN,
        ['build', filledFile, '--plan', '--out', join(output, 'filled-world')]).toString();
      check('strahler build takes the page\'s plan with filling: three more stages',
        filledPrinted.includes('258 tasks in 6 stages') && filledPrinted.includes('the depressions filled'),
        filledPrinted);
      // The world's preview built in the page: the bytes of the build's first task.
      const small = await page.evaluate(() => window.strahler.worldPlan({ size: 513, world: 129, tile: 128 }));
      const smallFile = join(output, 'small-plan.json');
      writeFileSync(smallFile, JSON.stringify(small));
      // A finished task is skipped: a world left by an earlier run would be read back as it was.
      rmSync(join(output, 'small-world'), { recursive: true, force: true });
      execFileSync(process.env.STRAHLER_BIN,
        ['build', smallFile, '--task', '0', '--out', join(output, 'small-world')]);
      const preview = await page.evaluate(async () =>
        Array.from(await window.strahler.worldPreview({ size: 513, world: 129, tile: 128 })));
      const written = readFileSync(join(output, 'small-world', 'preview.tif'));
      check('worldPreview() gives the bytes of the build\'s preview.tif',
        preview.length === written.length && written.every((b, i) => b === preview[i]),
        `${preview.length} bytes against ${written.length}`);
    }
    await goldenScenes(page, mode);
    // Back to the first scene for the edits below.
    await page.evaluate((s) => window.strahler.loadScene(s), scene);
    await page.waitForFunction(() => window.strahler.status().job === null, null, { timeout: 120_000 });
    const passes = await page.evaluate(passesOfEdit,
      'strahler.addRiver([1.0, 0.25], [0.7, 0.3], { phi: 2, depth: 7 })');
    console.log(`  addRiver(): ${passes.map((p) => `${p.pass} ${p.width}^2 after ${p.ms.toFixed(0)} ms`).join(', ')}`);
    check('addRiver() adds a river and regenerates, a coarse pass first',
      (await page.evaluate(() => window.strahler.scene().rivers.length)) === 2
      && passes.map((p) => `${p.pass} ${p.width}`).join(', ') === 'coarse 128, full 512',
      JSON.stringify(passes));
    const bad = await page.evaluate(() => {
      try { window.strahler.loadScene({ version: 1, rivers: [{ estuary: [0.5, 1], toward: [0.5, 0.3], phi: 9 }] }); return null; }
      catch (e) { return String(e.message); }
    });
    check('loadScene() names a bad field', bad !== null && bad.includes('rivers[0].phi'), String(bad));
    check('a refused scene changes nothing', (await page.evaluate(() => window.strahler.scene().rivers.length)) === 2);
    // Wavelet levels of detail and the energy-reduction mask (seed paper 001).
    await page.evaluate(() => {
      const s = window.strahler.scene();
      s.size = 256;
      s.detail = { levels: 1, scope: 'global', window: 3 };
      window.strahler.loadScene(s);
    });
    await page.waitForFunction(() => {
      const s = window.strahler.status();
      return s.job === null && s.detail !== null && s.detail.width === 511;
    }, null, { timeout: 120_000 });
    check('one detail level turns 256 cells into 511', true);
    await page.evaluate(() => window.strahler.paintMask([0.1, 0.5], [0.9, 0.5], { radius: 24, hardness: 0.9 }));
    await page.waitForFunction(() => {
      const s = window.strahler.status();
      return s.job === null && s.detail !== null && s.detail.rmsMasked !== null;
    }, null, { timeout: 120_000 });
    const detail = await page.evaluate(() => window.strahler.status().detail);
    check('a painted mask removes the detail under it and keeps it elsewhere',
      detail.rmsUnmasked > 0 && detail.rmsMasked < 0.1 * detail.rmsUnmasked, JSON.stringify(detail));
    await page.evaluate(() => window.strahler.maskFromRivers());
    await page.waitForFunction((old) => {
      const s = window.strahler.status();
      return s.job === null && s.detail !== null && s.detail.maskCells !== old;
    }, detail.maskCells, { timeout: 120_000 });
    const maskPng = await page.evaluate(() => window.strahler.scene().detail.mask_png);
    check('maskFromRivers() makes a mask saved in the scene as a PNG',
      typeof maskPng === 'string' && Buffer.from(maskPng, 'base64').subarray(1, 4).toString() === 'PNG');
    // Uplift painted by a script goes to the scene's erosion masks, not the detail's mask.
    await page.evaluate(() => window.strahler.paintMask([0.2, 0.3], [0.8, 0.35], { radius: 20, target: 'uplift' }));
    const painted = await page.evaluate(() => window.strahler.scene());
    check('paintMask({target: "uplift"}) paints the scene\'s uplift mask and leaves the detail mask',
      typeof painted.erosion_masks?.uplift_png === 'string' && painted.detail.mask_png === maskPng,
      JSON.stringify(Object.keys(painted.erosion_masks ?? {})));
    const refusedTarget = await page.evaluate(() => {
      try { window.strahler.paintMask([0, 0], [1, 1], { target: 'lava' }); return null; } catch (e) { return String(e); }
    });
    check('paintMask refuses an unknown target, naming the choices',
      refusedTarget !== null && refusedTarget.includes('hard-rock'), String(refusedTarget));
    // No DEM is uploaded yet: the app refuses the command, and its promise says why.
    const noDem = await page.evaluate(async () => {
      try { await window.strahler.extractFeatures(); return null; } catch (e) { return String(e); }
    });
    check('a command the app refuses rejects its promise with the app\'s message (extractFeatures before any DEM)',
      noDem !== null && noDem.includes('Upload a DEM first'), String(noDem));
    await page.waitForFunction(() => window.strahler.status().job === null, null, { timeout: 120_000 });
    if (mode === 'webgpu') {
      // Every stage on the GPU (generate's backend option): the wavelet statistics run in
      // WGSL in the page too (beside a software adapter 'auto' keeps them on the CPU).
      const runs = await page.evaluate(async () => {
        const s = window.strahler.scene();
        s.detail = { ...s.detail, scope: 'local' };
        await window.strahler.loadScene(s);
        // Every stage, erosion's WGSL solver included.
        const every = await window.strahler.generate({ size: 256, backend: 'gpu' });
        // The detail stage alone compared: without erosion both backends detail the same
        // terrain (the WGSL erosion leaves a slightly different one, about 1% of the relief
        // apart, whose local statistics differ by up to a fifth).
        await window.strahler.loadScene({ ...s, erosion: null });
        const gpu = await window.strahler.generate({ size: 256, backend: 'gpu' });
        const cpu = await window.strahler.generate({ size: 256, backend: 'cpu' });
        await window.strahler.loadScene(s);
        let refused = null;
        try { await window.strahler.generate({ size: 256, backend: 'tpu' }); }
        catch (e) { refused = String(e.message || e); }
        return {
          every: { detail: every.detail, erosion: every.erosion ? every.erosion.backend : null },
          gpu: gpu.detail, cpu: cpu.detail, refused,
        };
      });
      // The same amounts of detail, free and under the rivers' mask.
      const { every, gpu, cpu } = runs;
      const near = (a, b) => Math.abs(a - b) <= 0.15 * b;
      check('generate({backend: "gpu"}) runs every stage on the GPU, erosion included',
        every.erosion === 'gpu' && every.detail && every.detail.backend === 'gpu'
          && every.detail.width === 511 && every.detail.rms_unmasked > 0, JSON.stringify(every));
      check('generate({backend: "gpu"}) runs the local-scope detail on the GPU like the CPU',
        gpu && cpu && gpu.backend === 'gpu' && cpu.backend === 'cpu' && gpu.width === 511
          && cpu.rms_unmasked > 0 && near(gpu.rms_unmasked, cpu.rms_unmasked)
          && cpu.rms_masked !== null && near(gpu.rms_masked, cpu.rms_masked), JSON.stringify(runs));
      check('generate() names a backend it does not know', runs.refused !== null
        && runs.refused.includes('tpu'), String(runs.refused));
    }
    // A real DEM: uploaded through the file picker (the U key opens it, as the Upload DEM
    // button does), a block of it blended in (Poisson), and the heightmap exported.
    // A click on the map (pan tool: no edit) gives the canvas the keyboard focus. The CPU
    // path may still be finishing a frame, so the key is pressed again if no picker opened.
    await page.mouse.click(900, 400);
    let chooser = null;
    for (let attempt = 0; attempt < 3 && chooser === null; attempt += 1) {
      await page.waitForTimeout(500);
      [chooser] = await Promise.all([
        page.waitForEvent('filechooser', { timeout: 8_000 }).catch(() => null),
        page.keyboard.press('u'),
      ]);
    }
    check('the U key opens the Upload DEM file picker', chooser !== null);
    await chooser.setFiles(join(here, '..', '..', 'tests', 'data', 'volcano_maungawhau.tif'));
    await page.waitForFunction(() => window.strahler.status().dem !== null, null, { timeout: 30_000 });
    const dem = await page.evaluate(() => window.strahler.status().dem);
    check('the Upload DEM picker reads a GeoTIFF into the DEM panel',
      dem.width === 87 && dem.height === 61 && dem.zmin >= 94 && dem.zmax <= 196, JSON.stringify(dem));
    const badPlace = await page.evaluate(() => {
      try { window.strahler.placeBlock({ window: [0, 0, 10] }); return null; } catch (e) { return String(e); }
    });
    check('placeBlock() explains a bad argument', badPlace !== null && badPlace.includes('window'), String(badPlace));
    await page.evaluate(() => window.strahler.placeBlock({ window: [0, 10, 61, 61], rect: [0.3, 0.3, 0.6, 0.6] }));
    await page.waitForFunction(() => {
      const s = window.strahler.status();
      return s.job === null && s.blend !== null;
    }, null, { timeout: 120_000 });
    const blend = await page.evaluate(() => window.strahler.status().blend);
    check('placeBlock() blends the DEM block into the terrain', blend.blocks === 1 && blend.converged
      && blend.backend === 'cpu', JSON.stringify(blend));
    check('the block is saved in the scene', (await page.evaluate(() => window.strahler.scene().blend.length)) === 1);
    const feather = await page.evaluate(() => window.strahler.scene().blend[0].feather);
    check('a placed block fades in over a quarter of its side (its feather)', feather === 0.25, String(feather));
    const exported = await page.evaluate(async () => {
      const head = (b) => Array.from(b.slice(0, 24));
      const png = await window.strahler.exportHeightmap('png');
      const r16 = await window.strahler.exportHeightmap('r16', { size: 257, flipY: true });
      const tif = await window.strahler.exportHeightmap('tif');
      const obj = new TextDecoder().decode(await window.strahler.exportHeightmap('obj', { size: 65 }));
      let bad = null;
      try { await window.strahler.exportHeightmap('bmp'); } catch (e) { bad = String(e); }
      return { png: head(png), r16: r16.length, tif: head(tif),
        objVertices: obj.split('\n').filter((l) => l.startsWith('v ')).length, bad,
        width: window.strahler.status().terrain.width };
    });
    const pngWidth = Buffer.from(exported.png).readUInt32BE(16);
    check('exportHeightmap(png) is a PNG of the terrain',
      Buffer.from(exported.png).subarray(1, 4).toString() === 'PNG' && pngWidth === exported.width,
      JSON.stringify(exported));
    check('exportHeightmap(r16, {size: 257}) has 257 x 257 16-bit samples', exported.r16 === 257 * 257 * 2);
    check('exportHeightmap(tif) is a TIFF', Buffer.from(exported.tif).subarray(0, 4).toString('hex') === '49492a00'
      || Buffer.from(exported.tif).subarray(0, 4).toString('hex') === '4d4d002a');
    check('exportHeightmap(obj, {size: 65}) has 65 x 65 vertices', exported.objVertices === 65 * 65);
    check('exportHeightmap() names an unknown format', exported.bad !== null && exported.bad.includes('unknown format'));
    // Engine exports: a Unity preset with maps and the rivers is one zip of every file; EXR
    // and R32 hold float heights; an unknown preset is named.
    const engine = await page.evaluate(async () => {
      const zip = await window.strahler.exportHeightmap('r16',
        { preset: 'unity', maps: ['normal', 'splat'], rivers: true });
      const exr = await window.strahler.exportHeightmap('exr');
      const r32 = await window.strahler.exportHeightmap('r32', { size: 129 });
      let bad = null;
      try { await window.strahler.exportHeightmap('png', { preset: 'cryengine' }); } catch (e) { bad = String(e); }
      return { zip: Array.from(zip), exr: Array.from(exr.slice(0, 4)), r32: r32.length, bad };
    });
    const zip = Buffer.from(engine.zip);
    const names = ['strahler-heightmap.r16', 'strahler-heightmap.json', 'strahler-heightmap-unity.txt',
      'strahler-heightmap-normal.png', 'strahler-heightmap-splat.png', 'strahler-heightmap-rivers.geojson'];
    check('exportHeightmap(r16, {preset: unity, maps, rivers}) is one zip of every file',
      zip.subarray(0, 4).toString('hex') === '504b0304' && names.every((n) => zip.includes(n)),
      names.filter((n) => !zip.includes(n)).join(', '));
    check('exportHeightmap(exr) is an OpenEXR file', Buffer.from(engine.exr).toString('hex') === '762f3101');
    check('exportHeightmap(r32, {size: 129}) has 129 x 129 float samples', engine.r32 === 129 * 129 * 4);
    check('exportHeightmap() names an unknown preset', engine.bad !== null && engine.bad.includes('unknown preset'));
    // The editor with the mouse: draw a river on the canvas, undo and redo it, download a
    // 16-bit PNG through the export dialog, and find the scene again after a reload.
    const rivers = () => page.evaluate(() => window.strahler.scene().rivers.length);
    const riversBefore = await rivers();
    const lastChecksum = () => page.evaluate(() => window.strahler.status().lastRun?.checksum);
    const oldChecksum = await lastChecksum();
    await page.mouse.click(900, 400);
    await page.keyboard.press('r');
    await page.mouse.move(1050, 250);
    await page.mouse.down();
    for (let k = 1; k <= 10; k += 1) await page.mouse.move(1050 - 15 * k, 250 + 5 * k);
    await page.mouse.up();
    await page.waitForFunction((n) => window.strahler.scene().rivers.length === n + 1, riversBefore, { timeout: 20_000 })
      .catch(() => null);
    check('a river drawn with the mouse on the canvas is added', (await rivers()) === riversBefore + 1);
    await page.waitForFunction((old) => {
      const s = window.strahler.status();
      return s.job === null && s.lastRun !== null && s.lastRun.checksum !== old;
    }, oldChecksum, { timeout: 120_000 }).catch(() => null);
    check('the drawn river regenerates the terrain', (await lastChecksum()) !== oldChecksum);
    await page.evaluate(() => window.strahler.undo());
    await page.waitForFunction((n) => window.strahler.scene().rivers.length === n, riversBefore, { timeout: 20_000 })
      .catch(() => null);
    check('undo() removes the drawn river', (await rivers()) === riversBefore);
    await page.evaluate(() => window.strahler.redo());
    await page.waitForFunction((n) => window.strahler.scene().rivers.length === n + 1, riversBefore, { timeout: 20_000 })
      .catch(() => null);
    check('redo() brings it back', (await rivers()) === riversBefore + 1);
    await page.waitForFunction(() => window.strahler.status().job === null, null, { timeout: 120_000 });
    await page.mouse.click(900, 400);
    await page.keyboard.press('e');
    await page.waitForTimeout(500);
    // The PNG and its sidecar JSON download one after the other, in either order.
    const downloads = [];
    const collect = (d) => downloads.push(d);
    page.on('download', collect);
    await page.keyboard.press('Enter');
    const deadline = Date.now() + 20_000;
    while (Date.now() < deadline && !downloads.some((d) => d.suggestedFilename().endsWith('.png'))) {
      await page.waitForTimeout(100);
    }
    page.off('download', collect);
    const download = downloads.find((d) => d.suggestedFilename().endsWith('.png')) ?? null;
    let pngInfo = null;
    if (download !== null) {
      const saved = join(output, `${mode}-${download.suggestedFilename()}`);
      await download.saveAs(saved);
      const bytes = readFileSync(saved);
      // IHDR: width, height, bit depth; tEXt strahler:z_range = "min,max". The chunk's
      // length (4 bytes) and type stand before its keyword: the value ends there, not at the
      // first byte that is no digit (the CRC after it may start with one, or with '-').
      const text = bytes.toString('latin1');
      const at = text.indexOf('strahler:z_range');
      const length = at >= 8 ? bytes.readUInt32BE(at - 8) : 0;
      const range = at >= 8 ? text.slice(at + 17, at + length).split(',').map(Number) : null;
      pngInfo = { name: download.suggestedFilename(), width: bytes.readUInt32BE(16),
        height: bytes.readUInt32BE(20), depth: bytes[24], range };
    }
    const terrainSize = await page.evaluate(() => window.strahler.status().terrain.width);
    check('the export dialog downloads a 16-bit PNG of the terrain with real relief',
      pngInfo !== null && pngInfo.name.endsWith('.png') && pngInfo.width === terrainSize
        && pngInfo.height === terrainSize && pngInfo.depth === 16 && pngInfo.range !== null
        && pngInfo.range[1] - pngInfo.range[0] > 100, JSON.stringify(pngInfo));
    await page.keyboard.press('Escape');
    await check3d(page, mode);
    const sceneBefore = await page.evaluate(() => JSON.stringify(window.strahler.scene().rivers));
    await page.waitForTimeout(2500); // autosave runs every 2 s
    await page.reload();
    await page.waitForFunction(() => window.strahler?.status().ready === true, null, { timeout: 90_000 });
    await page.waitForFunction(() => window.strahler.scene() !== null, null, { timeout: 30_000 });
    const sceneAfter = await page.evaluate(() => JSON.stringify(window.strahler.scene().rivers));
    check('a reload restores the autosaved scene', sceneAfter === sceneBefore, `${sceneBefore} vs ${sceneAfter}`);
    // Issue 35: the undo history survives the reload too (the newest steps that fit).
    const undoAfter = await page.evaluate(() => window.strahler.status().undo);
    check('a reload keeps the undo history', undoAfter >= 1, `undo steps after the reload: ${undoAfter}`);
    // ... and the uploaded DEM, bit for bit (kept in IndexedDB).
    const demAfter = await page.waitForFunction(() => window.strahler.status().dem, null, { timeout: 30_000 })
      .then((handle) => handle.jsonValue()).catch(() => null);
    check('a reload keeps the uploaded DEM bit for bit', demAfter !== null && demAfter.checksum === dem.checksum
      && demAfter.name === dem.name && demAfter.width === dem.width, `${JSON.stringify(dem)} vs ${JSON.stringify(demAfter)}`);
    // A scripted edit is autosaved too (the autosave follows changes, not frames): wait for
    // the terrain, leave the page idle a little over 2 s, reload.
    await page.evaluate(() => window.strahler.addRiver([0.0, 0.8], [0.3, 0.75], { phi: 2, depth: 4 }));
    await page.waitForFunction(() => window.strahler.status().job === null, null, { timeout: 120_000 });
    const scripted = await page.evaluate(() => JSON.stringify(window.strahler.scene().rivers));
    await page.waitForTimeout(2500);
    await page.reload();
    await page.waitForFunction(() => window.strahler?.status().ready === true, null, { timeout: 90_000 });
    await page.waitForFunction(() => window.strahler.scene() !== null, null, { timeout: 30_000 });
    const restored = await page.evaluate(() => JSON.stringify(window.strahler.scene().rivers));
    check('a scripted edit is autosaved within 2 s and restored after a reload', restored === scripted,
      `${scripted} vs ${restored}`);
    await page.screenshot({ path: join(output, `${mode}.png`) });
    // The restored scene's terrain once built, to look at.
    await page.waitForFunction(() => window.strahler.status().job === null, null, { timeout: 120_000 });
    await page.screenshot({ path: join(output, `${mode}-terrain.png`) });
    // Issue 32: the uploaded DEM's features become the scene, which erodes as a rebuild of
    // the DEM (its valleys run on to their outlets).
    // After the reload: the DEM back from IndexedDB and the restored scene's terrain built
    // (an extraction before the DEM is back is refused: "Upload a DEM first").
    await page.waitForFunction(() => window.strahler.status().dem !== null
      && window.strahler.status().job === null, null, { timeout: 120_000 });
    const before = await page.evaluate(() => window.strahler.status().lastRun?.checksum);
    // The promise resolves once the features are the scene (and its terrain is built).
    await page.evaluate(() => window.strahler.extractFeatures());
    const preset = await page.evaluate(() => window.strahler.scene().erosion?.preset);
    check('extractFeatures() resolves once the features are the scene', preset === 'rebuild', String(preset));
    await page.waitForFunction((old) => {
      const s = window.strahler.status();
      return window.strahler.scene()?.erosion?.preset === 'rebuild' && s.job === null
        && s.lastRun?.checksum !== old;
    }, before, { timeout: 120_000 });
    const rebuilt = await page.evaluate(() => {
      const s = window.strahler.scene();
      const run = window.strahler.status().lastRun;
      const k = s.sketch;
      return { size: s.size, rivers: s.rivers.length, lines: k.ridges.length + k.valleys.length,
        peaks: k.peaks.length, relief: run.max - run.min };
    });
    check('extractFeatures() makes the DEM\'s features the scene and rebuilds it with erosion',
      rebuilt.size === 87 && rebuilt.rivers === 0 && rebuilt.lines > 0 && rebuilt.peaks > 0
        && rebuilt.relief > 30 && rebuilt.relief < 200, JSON.stringify(rebuilt));
    check('no page errors', pageErrors.length === 0, pageErrors.join('\n'));
    // Every GPU kernel (the 3D view's too) compiled in this browser at start.
    if (mode === 'webgpu') {
      const unbuilt = consoleWarnings.filter((w) => w.includes('builds its kernels when it first runs'));
      check('every GPU kernel was built at start', unbuilt.length === 0, unbuilt.join('\n'));
    }
    if (consoleErrors.length > 0) console.log(`  console errors (not failures):\n    ${consoleErrors.join('\n    ')}`);
  } catch (err) {
    check(`page runs without exceptions`, false, String(err));
    if (pageErrors.length > 0) console.log(`  page errors:\n    ${pageErrors.join('\n    ')}`);
    if (consoleErrors.length > 0) console.log(`  console errors:\n    ${consoleErrors.join('\n    ')}`);
  } finally {
    await browser.close();
  }
}

// The 3D view (WebGPU, or WebGL2 on the CPU fallback): setView/setCamera, the LoD responding
// to the camera, terrain actually drawn, a mouse drag turning the camera, F to fly.
// The golden scenes of tests/data/scenes: loaded through the awaitable loadScene(), read
// back deep-equal, and on the CPU path generated with the checksums the library and the
// command line pin (same scene, same bits, natively and in the browser).
async function goldenScenes(page, mode) {
  const dir = join(here, '..', '..', 'tests', 'data', 'scenes');
  const pinned = JSON.parse(readFileSync(join(dir, 'checksums.json'), 'utf8'));
  for (const name of ['sketch', 'detail', 'block', 'mesas', 'meanders', 'every_field']) {
    const scene = JSON.parse(readFileSync(join(dir, `${name}.json`), 'utf8'));
    // The promise resolves once the app applied the scene: no polling.
    await page.evaluate((s) => window.strahler.loadScene(s), scene);
    const back = await page.evaluate(() => window.strahler.scene());
    check(`loadScene(${name}) then scene() gives it back deep-equal`,
      JSON.stringify(back) === JSON.stringify(scene), JSON.stringify(back).slice(0, 200));
    if (mode === 'cpu' && pinned[name]) {
      const report = await page.evaluate(() => window.strahler.generate({}));
      check(`the page makes the pinned terrain of scene ${name}`, report.checksum === pinned[name],
        `${report.checksum} != ${pinned[name]}`);
      if (report.erosion) {
        check(`scene ${name}: the erosion ran in the Web Worker`, report.erosion.in_worker === true,
          JSON.stringify(report.erosion).slice(0, 120));
      }
    }
  }
  // exportHeightmap() waits for the terrain being computed instead of failing.
  const bytes = await page.evaluate(async () => Array.from(await window.strahler.exportHeightmap('tif')));
  check('exportHeightmap() waits for the terrain of the scene just loaded', bytes.length > 1000,
    String(bytes.length));
  // The last scene (every_field) is placed at 45.9 N, 6.9 E: its GeoTIFF is in UTM zone 32N.
  const keys = geoKeys(Buffer.from(bytes));
  check('a scene placed on Earth exports its GeoTIFF in its UTM zone (EPSG 32632)',
    keys !== null && keys.join(',').includes('3072,0,1,32632'), String(keys));
}

// The GeoKeyDirectory (tag 34735) of a classic TIFF's first image, as numbers, or null.
function geoKeys(b) {
  const le = b.toString('latin1', 0, 2) === 'II';
  const u16 = (o) => (le ? b.readUInt16LE(o) : b.readUInt16BE(o));
  const u32 = (o) => (le ? b.readUInt32LE(o) : b.readUInt32BE(o));
  if (u16(2) !== 42) return null;
  const ifd = u32(4);
  for (let i = 0; i < u16(ifd); i += 1) {
    const entry = ifd + 2 + 12 * i;
    if (u16(entry) !== 34735) continue;
    const count = u32(entry + 4);
    const at = count <= 2 ? entry + 8 : u32(entry + 8);
    return Array.from({ length: count }, (_, k) => u16(at + 2 * k));
  }
  return null;
}

// Distinct colours (5 bits a channel) in the middle of the 3D area: lit terrain has many,
// a flat fill or the sky few.
function shadedColours(shot) {
  const colours = new Set();
  for (let y = 300; y < 600; y += 6) {
    for (let x = 450; x < 850; x += 6) {
      const p = shot.pixel(x, y);
      colours.add((p[0] >> 3) * 1024 + (p[1] >> 3) * 32 + (p[2] >> 3));
    }
  }
  return colours.size;
}

async function check3d(page, mode) {
  const view3d = () => page.evaluate(() => window.strahler.status().view3d);
  await page.evaluate(() => window.strahler.setView('3d'));
  await page.waitForFunction(() => window.strahler.status().view3d !== null, null, { timeout: 30_000 })
    .catch(() => null);
  const first = await view3d();
  check('setView(3d) shows the 3D view', (await page.evaluate(() => window.strahler.status().view)) === '3d'
    && first !== null && first.triangles > 0 && first.chunks > 0, JSON.stringify(first));
  const at = async (camera) => {
    await page.evaluate((c) => window.strahler.setCamera(c), camera);
    await page.waitForFunction((d) => Math.abs(window.strahler.status().view3d.distance - d) < 1e-3,
      camera.distance, { timeout: 20_000 }).catch(() => null);
    await page.waitForTimeout(300);
    return view3d();
  };
  const near = await at({ distance: 0.05, yaw: 30, pitch: 20 });
  const far = await at({ distance: 3, yaw: 30, pitch: 35 });
  check('the LoD draws at least twice the triangles near the ground as from 3 map widths',
    near.triangles >= 2 * far.triangles && near.finestLevel < far.finestLevel,
    `${JSON.stringify(near)} ${JSON.stringify(far)}`);
  const bad = await page.evaluate(() => {
    try { window.strahler.setCamera({ distance: 'far' }); return null; } catch (e) { return String(e); }
  });
  check('setCamera() explains a bad argument', bad !== null && bad.includes('distance'), String(bad));
  const overview = await at({ distance: 1.2, yaw: 0, pitch: 35 });
  const shot = decodePng(await page.screenshot({ path: join(output, `${mode}-3d.png`) }));
  const colours = shadedColours(shot);
  check('the 3D view draws shaded terrain', colours > 40, `${colours} colours`);
  // A mouse drag on the view turns the camera.
  await page.mouse.move(650, 450);
  await page.mouse.down();
  for (let k = 1; k <= 8; k += 1) await page.mouse.move(650 + 15 * k, 450);
  await page.mouse.up();
  await page.waitForTimeout(300);
  const turned = await view3d();
  check('dragging on the 3D view turns the camera', Math.abs(turned.yaw - overview.yaw) > 5,
    `${overview.yaw} -> ${turned.yaw}`);
  await page.keyboard.press('f');
  await page.waitForFunction(() => window.strahler.status().view3d.mode === 'fly', null, { timeout: 5_000 })
    .catch(() => null);
  check('F switches to the fly camera', (await view3d()).mode === 'fly');
  if (mode === 'webgpu') {
    // The rasters made on the page's GPU (what a hardware GPU does by default), reading the
    // terrain from the pipeline's own GPU copy (so computed on the GPU: "Compute on: gpu",
    // auto's choice on hardware): the WGSL runs in the browser's compiler.
    await page.evaluate(() => window.strahler.setCompute('gpu'));
    await page.evaluate(() => window.strahler.setView('3d', { maps: 'gpu' }));
    await page.waitForFunction(() => window.strahler.status().view3d?.maps === 'gpu', null,
      { timeout: 60_000 }).catch(() => null);
    await page.keyboard.press('Home');
    await page.waitForTimeout(500);
    const made = await view3d();
    check("the page makes the 3D maps on its GPU from the pipeline's GPU copy of the terrain",
      made?.maps === 'gpu' && made.fromGpuCopy === true && made.triangles > 0, JSON.stringify(made));
    const gpuShot = decodePng(await page.screenshot({ path: join(output, `${mode}-3d-gpu-maps.png`) }));
    const shades = shadedColours(gpuShot);
    check('the 3D view draws shaded terrain from GPU-made maps', shades > 40, `${shades} colours`);
    const badMaps = await page.evaluate(() => {
      try { window.strahler.setView('3d', { maps: 'tpu' }); return null; } catch (e) { return e.message; }
    });
    check('setView() names a bad maps choice', badMaps !== null && badMaps.includes('maps'), String(badMaps));
    await page.evaluate(() => window.strahler.setView('3d', { maps: 'auto' }));
  } else {
    const refused = await page.evaluate(() => {
      try { window.strahler.setView('3d', { maps: 'gpu' }); return null; } catch (e) { return e.message; }
    });
    check("setView('3d', {maps: 'gpu'}) explains that the page computes on the CPU",
      refused !== null && refused.includes('needs a GPU'), String(refused));
  }
  await page.evaluate(() => window.strahler.setView('2d'));
}

// A browser without (module) Web Workers: the page erodes on its own thread, with the bits
// the worker gives (the first terrain of the default scene, as in the runs before).
async function withoutWorkers(url) {
  console.log('browser (cpu, no Web Workers):');
  const browser = await chromium.launch({ executablePath: chromiumPath, args: COMMON_FLAGS });
  try {
    const page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
    await page.addInitScript(() => { window.Worker = undefined; });
    await page.goto(url);
    await page.waitForFunction(() => window.strahler?.status().ready === true, null, { timeout: 90_000 });
    await page.waitForFunction(() => window.strahler.status().lastRun !== null
      && window.strahler.status().job === null, null, { timeout: 120_000 });
    const status = await page.evaluate(() => window.strahler.status());
    check('without Web Workers the status says the diffusion and the erosion run on the page',
      /^no Web Worker \(.+\): the diffusion and the erosion run on the page$/.test(status.worker ?? ''), String(status.worker));
    const expected = firstChecksums.cpu ?? firstChecksums.webgpu;
    check('without Web Workers the page makes the same terrain bits as with one',
      expected !== undefined && status.lastRun.checksum === expected, `${status.lastRun.checksum} != ${expected}`);
  } finally {
    await browser.close();
  }
}

if (!existsSync(join(dist, 'index.html'))) {
  console.error(`no ${join(dist, 'index.html')}: run \`.ci/build-web\` first`);
  process.exit(2);
}
// The WebGPU mode's page is not cross-origin isolated (its worker runs one thread); the CPU
// mode's is (the threaded build's pool): both must give the command line's bits.
const server = await serve(dist);
const isolatedServer = await serve(dist, { isolated: true });
const urlOf = (s) => `http://127.0.0.1:${s.address().port}/`;
const url = urlOf(server);
try {
  const expected = nativeChecksum();
  const modes = (process.env.BROWSER_MODES ?? 'webgpu,cpu').split(',');
  for (const mode of modes) await runMode(mode === 'cpu' ? urlOf(isolatedServer) : url, mode, expected);
  if (firstChecksums.cpu !== undefined && firstChecksums.webgpu !== undefined) {
    check('the first terrain has the same bits on one thread (WebGPU page) and on the pool (CPU page)',
      firstChecksums.cpu === firstChecksums.webgpu, `${firstChecksums.cpu} != ${firstChecksums.webgpu}`);
  }
  await withoutWorkers(url);
} finally {
  server.close();
  isolatedServer.close();
}
console.log(`browser: ${passed} passed, ${failed} failed`);
process.exit(failed === 0 ? 0 : 1);
