// Browser benchmark of the Trunk build (dist/) in headless Chromium: the editor's targets,
// measured on the WebGPU path and on the CPU fallback, printed as a table.
//
//   first terrain  ms from navigation start to the first terrain on the map, wasm cached
//                  (the page is loaded once before, then reloaded)
//   edit -> coarse ms from an edit (a new seed) to the first terrain on the map (the coarse
//                  128^2 pass), median of 5
//   edit -> map    ms from the edit to the regenerated 512^2 preview on the map,
//                  median of 5 (and the slowest); `diffuse` is the diffusion stage's own time
//   2048^2 frames  animation-frame intervals while `generate({size: 2048})` runs on the page:
//                  median, 95th percentile and longest, and how long the generation took;
//                  main-thread tasks over 50 ms meanwhile (PerformanceObserver 'longtask':
//                  the page's own work, without the browser's compositing) and the longest
//   3D orbit       camera turns the 3D view draws a second while it is turned every animation
//                  frame: idle, and while a 2048^2 terrain is generated (BENCH_ORBIT=0 skips)
//   exports        an Unreal export at 4033^2 from the map's terrain, alone and with the
//                  normal and splat maps and the rivers (one zip): its time, the frame gaps
//                  and the main-thread tasks over 50 ms meanwhile (both paths;
//                  BENCH_EXPORT=0 skips it, BENCH_EXPORT=only measures nothing else)
//   threads        (BENCH_THREADS=only, or =1 besides the rest) `generate()` at 1024^2, 2048^2
//                  and 4096^2 (BENCH_THREAD_SIZES) in a cross-origin isolated page whose stages
//                  worker runs the threaded build, on one thread (`?threads=1`) and on the
//                  machine's cores: the time, the diffusion's and the erosion's, and whether
//                  the bits are the same
//   hydrology      the stages before diffusion at 2048^2 on the scene of `strahler bench
//                  --pipeline` (four rivers, phi 2 to 4), median of 3 generations on the CPU
//                  path (they run on the page's own thread, whose build has no threads; these
//                  stages never use the GPU)
//
// Usage: node web/tests/bench.mjs [DIST_DIR]
//   (env: CHROMIUM, BROWSER_MODES, BENCH_COMPUTE, BENCH_4096, BENCH_EXPORT, BENCH_NO_WORKER, BENCH_ORBIT,
//    BENCH_ISOLATED, BENCH_THREADS, BENCH_THREAD_SIZES)

import { existsSync } from 'node:fs';
import { join, resolve } from 'node:path';
import { chromium } from 'playwright-core';
import { COMMON_FLAGS, WEBGPU_FLAGS, serve } from './harness.mjs';

const here = new URL('.', import.meta.url).pathname;
const dist = resolve(process.argv[2] ?? join(here, '..', '..', 'dist'));
const chromiumPath = process.env.CHROMIUM ?? '/usr/bin/chromium';

// Runs in the page before its scripts: records when the first terrain appears.
function watchFirstTerrain() {
  const poll = () => {
    if (window.strahler?.status().lastRun) window.__firstTerrain = performance.now();
    else setTimeout(poll, 5);
  };
  poll();
}

// Runs in the page: the hydrology stages of three 2048^2 generations of the native
// benchmark's scene, each stage's median.
async function hydrologyStages() {
  const scene = window.strahler.scene();
  scene.cell_size = 10000 / 2048;
  scene.seed = 1;
  scene.rivers = [
    { estuary: [0.5, 1.0], toward: [0.5, 0.55], phi: 2, depth: 16 },
    { estuary: [0.0, 0.3], toward: [0.35, 0.25], phi: 3, depth: 16 },
    { estuary: [1.0, 0.35], toward: [0.65, 0.3], phi: 4, depth: 14 },
    { estuary: [0.5, 0.0], toward: [0.5, 0.25], phi: 3, depth: 16 },
  ];
  window.strahler.loadScene(scene);
  // The page takes the scene on its next frame and regenerates its preview: wait for both, so
  // that no job of the page's shares the thread with the timed generations.
  const settled = () => window.strahler.scene().rivers.length === scene.rivers.length
    && window.strahler.status().job === null;
  const pause = (ms) => new Promise((done) => setTimeout(done, ms));
  let calm = 0;
  while (calm < 5) {
    calm = settled() ? calm + 1 : 0;
    await pause(40);
  }
  const names = ['rivers', 'ridges', 'skeleton', 'enrich'];
  const runs = [];
  for (let i = 0; i < 3; i += 1) {
    const report = await window.strahler.generate({ size: 2048 });
    const ms = names.map((name) => report.stages.find((s) => s.name === name)?.ms ?? 0);
    runs.push({ nodes: report.rivers.nodes, ms: [...ms, ms.reduce((a, b) => a + b)] });
  }
  const median = (k) => runs.map((r) => r.ms[k]).sort((a, b) => a - b)[1];
  return { nodes: runs[0].nodes, ms: names.map((_, k) => median(k)), total: median(names.length) };
}

// Runs in the page (installed as `window.watched`): `work()` timed with the animation-frame gaps and the main-thread tasks
// over 50 ms while it runs.
async function watched(work) {
  const tasks = [];
  const observer = new PerformanceObserver((list) => {
    for (const entry of list.getEntries()) tasks.push(entry.duration);
  });
  observer.observe({ type: 'longtask' });
  const gaps = [];
  let last = performance.now();
  let running = true;
  const tick = (now) => {
    gaps.push(now - last);
    last = now;
    if (running) requestAnimationFrame(tick);
  };
  requestAnimationFrame(tick);
  const start = performance.now();
  const result = await work();
  const total = performance.now() - start;
  running = false;
  // Long-task entries arrive asynchronously: give the last ones time to land.
  await new Promise((done) => setTimeout(done, 500));
  observer.disconnect();
  return { gaps, total, tasks, result };
}

// Runs in the page: the 3D view orbiting (the camera turned every animation frame), as
// frames the view drew with a new camera per second, idle and while a 2048^2 terrain is
// generated, then back to the map.
async function orbitRates() {
  const pause = (ms) => new Promise((done) => setTimeout(done, ms));
  window.strahler.setView('3d');
  await pause(2000);
  const orbitFor = async (work) => {
    let yaw = 0;
    let turning = true;
    const drawn = new Set();
    const turn = () => {
      if (!turning) return;
      yaw = (yaw + 1) % 360;
      window.strahler.setCamera({ yaw });
      const seen = window.strahler.status().view3d?.yaw;
      if (seen !== undefined) drawn.add(Math.round(seen * 1000));
      requestAnimationFrame(turn);
    };
    const start = performance.now();
    requestAnimationFrame(turn);
    await work();
    turning = false;
    return (drawn.size * 1000) / (performance.now() - start);
  };
  const idle = await orbitFor(() => pause(3000));
  let ms = 0;
  const building = await orbitFor(async () => {
    const start = performance.now();
    await window.strahler.generate({ size: 2048 });
    ms = performance.now() - start;
  });
  window.strahler.setView('2d');
  await pause(500);
  return { idle, building, ms };
}

// Runs in the page: two Unreal exports at 4033^2 of the terrain on the map, watched.
async function exports() {
  const watch = window.watched;
  const memory = () => window.strahler.status().memoryBytes;
  const before = memory();
  const plain = await watch(() => window.strahler.exportHeightmap('png', { preset: 'unreal', size: 4033 }));
  plain.memory = memory();
  const full = await watch(() => window.strahler.exportHeightmap('png',
    { preset: 'unreal', size: 4033, maps: ['normal', 'splat'], rivers: true }));
  full.memory = memory();
  const row = (name, w) => ({
    before, after: w.memory,
    name, ms: w.total, bytes: w.result.length, frames: w.gaps.length,
    longestGap: Math.max(0, ...w.gaps), tasks: w.tasks.length, longestTask: Math.max(0, ...w.tasks),
  });
  return [row('unreal 4033^2 PNG', plain), row('+ normal, splat, rivers (zip)', full)];
}

async function measure(url, mode) {
  const browser = await chromium.launch({
    executablePath: chromiumPath,
    args: [...COMMON_FLAGS, ...(mode === 'webgpu' ? WEBGPU_FLAGS : [])],
  });
  try {
    const page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
    await page.addInitScript(watchFirstTerrain);
    // BENCH_NO_WORKER=1: a browser without Web Workers, every stage on the page's thread.
    if (process.env.BENCH_NO_WORKER === '1') await page.addInitScript(() => { window.Worker = undefined; });
    await page.goto(url);
    await page.waitForFunction(() => window.__firstTerrain !== undefined, null, { timeout: 120_000 });
    await page.reload();
    await page.waitForFunction(() => window.__firstTerrain !== undefined, null, { timeout: 120_000 });
    const first = await page.evaluate(() => window.__firstTerrain);
    await page.waitForFunction(() => window.strahler.status().job === null, null, { timeout: 120_000 });
    // "Compute on" for the edits and the 2048^2 generation: auto (the default) computes on the
    // CPU beside SwiftShader; BENCH_COMPUTE=gpu measures the GPU path there.
    if (process.env.BENCH_COMPUTE) {
      await page.evaluate((choice) => window.strahler.setCompute(choice), process.env.BENCH_COMPUTE);
    }
    await page.evaluate(`window.watched = ${watched}`);
    if (process.env.BENCH_EXPORT === 'only') {
      return { mode, exportRows: await page.evaluate(exports) };
    }

    const edits = await page.evaluate(async () => {
      // The edit's runs until the page is idle: the first terrain on the map (its coarse
      // pass) and the last (the 512^2 preview).
      const idle = (old, start) => new Promise((done) => {
        let first = null;
        const poll = () => {
          const s = window.strahler.status();
          const changed = s.lastRun && s.lastRun.checksum !== old;
          if (changed && first === null) first = performance.now() - start;
          if (s.job === null && changed) done({ run: s.lastRun, first });
          else setTimeout(poll, 2);
        };
        poll();
      });
      const out = [];
      for (let seed = 11; seed < 16; seed += 1) {
        const old = window.strahler.status().lastRun.checksum;
        const scene = window.strahler.scene();
        scene.seed = seed;
        const start = performance.now();
        window.strahler.loadScene(scene);
        const { run, first } = await idle(old, start);
        out.push({ wall: performance.now() - start, first, job: run.millis, size: run.width ?? null });
      }
      return out;
    });
    const walls = edits.map((e) => e.wall).sort((a, b) => a - b);
    const firsts = edits.map((e) => e.first).sort((a, b) => a - b);
    const jobs = edits.map((e) => e.job).sort((a, b) => a - b);

    // Main-thread tasks over 50 ms (what the page's own work blocks), beside the frame gaps
    // (which also hold the browser's painting).
    const frames = await page.evaluate(() => window.watched(() => window.strahler.generate({ size: 2048 })));
    const orbit = process.env.BENCH_ORBIT === '0' ? null : await page.evaluate(orbitRates);
    const hydrology = mode === 'cpu' ? await page.evaluate(hydrologyStages) : null;
    // Peak memory of a 4096^2 generation of the default scene (the page's WebAssembly memory
    // only grows, so its size afterwards is the peak), on the CPU path only (SwiftShader
    // takes minutes at that size). BENCH_4096=0 skips it.
    const big = mode === 'cpu' && process.env.BENCH_4096 !== '0'
      ? await page.evaluate(async () => {
        const before = window.strahler.status().memoryBytes;
        const start = performance.now();
        const report = await window.strahler.generate({ size: 4096 });
        return { ms: performance.now() - start, before, after: window.strahler.status().memoryBytes,
          stages: report.stages.map((s) => `${s.name} ${s.ms.toFixed(0)}`).join(', ') };
      })
      : null;
    // Last: WebAssembly memory only grows, so the exports' peak would hide the 4096^2 one.
    const exportRows = process.env.BENCH_EXPORT !== '0' ? await page.evaluate(exports) : null;
    const gaps = frames.gaps.slice(1).sort((a, b) => a - b);
    const pick = (q) => gaps[Math.min(gaps.length - 1, Math.floor(q * gaps.length))];
    return {
      mode,
      first,
      coarse: firsts[Math.floor(firsts.length / 2)],
      edit: walls[Math.floor(walls.length / 2)],
      editMax: walls[walls.length - 1],
      job: jobs[Math.floor(jobs.length / 2)],
      generate: frames.total,
      frames: gaps.length,
      median: pick(0.5),
      p95: pick(0.95),
      longest: gaps[gaps.length - 1],
      longTasks: frames.tasks.length,
      longestTask: Math.max(0, ...frames.tasks),
      orbit,
      hydrology,
      big,
      exportRows,
    };
  } finally {
    await browser.close();
  }
}

// `generate()` at each size on `threads` threads (the page's `?threads=N`; null: the machine's
// cores, the page's default) in a cross-origin
// isolated page on the CPU path: [{size, threads, ms, diffuse, erosion, checksum}].
async function threadRuns(base, threads, sizes) {
  const browser = await chromium.launch({ executablePath: chromiumPath, args: COMMON_FLAGS });
  try {
    const page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
    await page.goto(threads ? `${base}?threads=${threads}` : base);
    await page.waitForFunction(() => window.strahler?.status().lastRun
      && window.strahler.status().job === null, null, { timeout: 120_000 });
    const started = (await page.evaluate(() => window.strahler.status())).threads;
    const runs = [];
    for (const size of sizes) {
      const run = await page.evaluate(async (n) => {
        const t = performance.now();
        const report = await window.strahler.generate({ size: n });
        const stage = (name) => report.stages.find((s) => s.name === name)?.ms ?? NaN;
        return { ms: performance.now() - t, diffuse: stage('diffuse'), erosion: stage('erosion'),
          checksum: report.checksum };
      }, size);
      runs.push({ size, threads: started, ...run });
    }
    return runs;
  } finally {
    await browser.close();
  }
}

async function threadsTable() {
  const isolated = await serve(dist, { isolated: true });
  const base = `http://127.0.0.1:${isolated.address().port}/`;
  const sizes = (process.env.BENCH_THREAD_SIZES ?? '1024,2048,4096').split(',').map(Number);
  try {
    const one = await threadRuns(base, 1, sizes);
    const all = await threadRuns(base, null, sizes);
    console.log('generate() in a cross-origin isolated page (CPU path, the stages worker\'s threads), milliseconds');
    console.log('size    threads   generate  diffuse  erosion | speed-up  same bits');
    const f = (v) => v.toFixed(0).padStart(8);
    one.forEach((a, k) => {
      const b = all[k];
      for (const r of [a, b]) {
        const extra = r === b ? ` | ${(a.ms / b.ms).toFixed(2).padStart(8)}  ${a.checksum === b.checksum}` : ' |';
        console.log(`${String(r.size).padEnd(7)} ${String(r.threads).padStart(7)} ${f(r.ms)} ${f(r.diffuse)} ${f(r.erosion)}${extra}`);
      }
    });
  } finally {
    isolated.close();
  }
}

if (!existsSync(join(dist, 'index.html'))) {
  console.error(`no ${join(dist, 'index.html')}: run \`.ci/build-web\` first`);
  process.exit(2);
}
if (process.env.BENCH_THREADS) await threadsTable();
if (process.env.BENCH_THREADS === 'only') process.exit(0);
// BENCH_ISOLATED=1: the editor's page cross-origin isolated, its worker on every core.
const server = await serve(dist, { isolated: process.env.BENCH_ISOLATED === '1' });
const url = `http://127.0.0.1:${server.address().port}/`;
const rows = [];
try {
  for (const mode of (process.env.BROWSER_MODES ?? 'webgpu,cpu').split(',')) {
    rows.push(await measure(url, mode));
  }
} finally {
  server.close();
}
const f = (v) => v.toFixed(0).padStart(7);
for (const r of rows.filter((row) => row.exportRows)) {
  console.log(`exports in the page (${r.mode}), milliseconds`);
  console.log('export                          time      bytes  frames  longest gap | tasks > 50 ms  longest'
    + ' | wasm memory MiB before, after (the peak so far)');
  const mib = (b) => (b / 2 ** 20).toFixed(0);
  for (const e of r.exportRows) {
    console.log(`${e.name.padEnd(30)} ${f(e.ms)} ${String(e.bytes).padStart(10)} ${String(e.frames).padStart(7)}`
      + `      ${f(e.ms && e.longestGap)} | ${String(e.tasks).padStart(13)} ${f(e.longestTask)}`
      + ` | ${mib(e.before)}, ${mib(e.after)}`);
  }
}
if (process.env.BENCH_EXPORT === 'only') {
  process.exit(0);
}
console.log('editor in headless Chromium, milliseconds');
console.log('path    first terrain  edit->coarse  edit->map (max) diffuse | 2048^2: generate  frames  median    p95  longest'
  + ' | tasks > 50 ms  longest');
for (const r of rows) {
  console.log(`${r.mode.padEnd(7)} ${f(r.first)}       ${f(r.coarse)}       ${f(r.edit)} (${f(r.editMax).trim()}) ${f(r.job)}   |`
    + `        ${f(r.generate)} ${String(r.frames).padStart(7)} ${f(r.median)} ${f(r.p95)} ${f(r.longest)}`
    + ` | ${String(r.longTasks).padStart(13)} ${f(r.longestTask)}`);
}
console.log('targets (editor issue): first terrain <= 3000; the coarse pass <= 300 and the 512^2 preview '
  + '<= 2000 on the CPU path; frames < 50 while a 2048^2 terrain is generated');
for (const r of rows.filter((row) => row.orbit)) {
  console.log(`3D view orbiting (${r.mode}): ${r.orbit.idle.toFixed(1)} drawn camera turns a second idle, `
    + `${r.orbit.building.toFixed(1)} while a 2048^2 terrain is generated (${r.orbit.ms.toFixed(0)} ms)`);
}
for (const r of rows.filter((row) => row.hydrology)) {
  const h = r.hydrology;
  console.log(`hydrology at 2048^2 in the page (${h.nodes} river nodes, median of 3): rivers `
    + `${h.ms[0].toFixed(1)}, ridges ${h.ms[1].toFixed(1)}, skeleton ${h.ms[2].toFixed(1)}, `
    + `enrich ${h.ms[3].toFixed(1)}, together ${h.total.toFixed(1)} ms `
    + '(target: at most twice the native 200 ms)');
}
for (const r of rows.filter((r) => r.big)) {
  console.log(`4096^2 generation in the page (${r.mode}): ${r.big.ms.toFixed(0)} ms (${r.big.stages}); `
    + `WebAssembly memory ${(r.big.before / 2 ** 20).toFixed(0)} MiB before, ${(r.big.after / 2 ** 20).toFixed(0)} MiB after (the peak)`);
}
