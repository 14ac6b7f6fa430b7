// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { isSoftwareRenderer, renderQuality, SOFTWARE_MAX_FPS } from '../src/render_quality.js';
import { DETAILED_MAX } from '../src/level_of_detail.js';

const SWIFTSHADER = 'ANGLE (Google, Vulkan 1.3.0 (SwiftShader Device (Subzero) (0x0000C0DE)), SwiftShader driver)';
const GPU = 'ANGLE (NVIDIA, NVIDIA GeForce RTX 3060 (0x00002503) Direct3D11 vs_5_0 ps_5_0, D3D11)';

test('software renderers are told from GPUs by their WebGL renderer string', () => {
  assert.equal(isSoftwareRenderer(SWIFTSHADER), true);
  assert.equal(isSoftwareRenderer('llvmpipe (LLVM 15.0.6, 256 bits)'), true);
  assert.equal(
    isSoftwareRenderer('ANGLE (Microsoft, Microsoft Basic Render Driver Direct3D11 vs_5_0 ps_5_0, D3D11)'),
    true,
  );
  assert.equal(isSoftwareRenderer(GPU), false);
  assert.equal(isSoftwareRenderer('Adreno (TM) 740'), false); // a Quest 3
  assert.equal(isSoftwareRenderer(null), false); // hidden: assume a GPU
});

test('quality drops by itself on a software renderer; the address overrides', () => {
  const none = new URLSearchParams('');
  assert.deepEqual(renderQuality(GPU, none), {
    lowQuality: false,
    maxFps: null,
    software: false,
    reason: '',
    detailedMax: DETAILED_MAX,
  });
  const soft = renderQuality(SWIFTSHADER, none);
  assert.equal(soft.lowQuality, true);
  assert.equal(soft.maxFps, SOFTWARE_MAX_FPS);
  assert.match(soft.reason, /^software rendering \(ANGLE.*robots as simple shapes/);
  assert.equal(soft.detailedMax, 0); // every robot the fleet's shared shape: full models held VR at 4.3 frames/s
  assert.deepEqual(renderQuality(SWIFTSHADER, new URLSearchParams('quality=high')), {
    lowQuality: false,
    maxFps: null,
    software: true,
    reason: '',
    detailedMax: DETAILED_MAX,
  });
  assert.equal(renderQuality(SWIFTSHADER, new URLSearchParams('maxfps=2')).maxFps, 2);
  assert.equal(renderQuality(GPU, new URLSearchParams('quality=low')).lowQuality, true);
  assert.equal(renderQuality(SWIFTSHADER, new URLSearchParams('detail=4')).detailedMax, 4);
  assert.equal(renderQuality(GPU, new URLSearchParams('detail=1')).detailedMax, 1);
  assert.equal(renderQuality(GPU, new URLSearchParams('detail=-2')).detailedMax, DETAILED_MAX); // not a count
});
