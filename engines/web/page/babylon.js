// Babylon.js: the exported glTF under the exported equirect map, rendered into a float render target (the
// camera's outputRenderTarget) and read back as linear radiance.
//   handedness: scene.useRightHandedSystem = true, so the glTF loader keeps glTF's right-handed axes as they are
//     (no __root__ node flipping z) and the camera is built in the same world as iblcheck's;
//   linear output: the materials' image processing deferred to a post-process that is never attached (see
//     below), tone mapping off, exposure 1, the final [0, 30] clamp skipped; no FXAA or other post-process;
//   environment: HDRCubeTexture (Babylon converts the equirect map to a cube on the CPU) with Babylon's own
//     GGX prefiltering (prefilterOnLoad) as scene.environmentTexture; diffuse from its spherical harmonics,
//     Babylon's default; the background a skybox of a second, unfiltered HDRCubeTexture (no mip chain, so it is
//     never a prefiltered level);
//   rotation: `rotationY` of both textures = quarter turn - theta (see ROTATION_SIGN and PANORAMA_TURN).
import { Engine } from "@babylonjs/core/Engines/engine.js";
import { Scene } from "@babylonjs/core/scene.js";
import { Constants } from "@babylonjs/core/Engines/constants.js";
import { HDRCubeTexture } from "@babylonjs/core/Materials/Textures/hdrCubeTexture.js";
import { Texture } from "@babylonjs/core/Materials/Textures/texture.js";
import { RenderTargetTexture } from "@babylonjs/core/Materials/Textures/renderTargetTexture.js";
import { PBRMaterial } from "@babylonjs/core/Materials/PBR/pbrMaterial.js";
import { FreeCamera } from "@babylonjs/core/Cameras/freeCamera.js";
import { Camera } from "@babylonjs/core/Cameras/camera.js";
import { CreateBox } from "@babylonjs/core/Meshes/Builders/boxBuilder.js";
import { Vector3 } from "@babylonjs/core/Maths/math.vector.js";
import { Color4 } from "@babylonjs/core/Maths/math.color.js";
import { AppendSceneAsync } from "@babylonjs/core/Loading/sceneLoader.js";
import "@babylonjs/core/Loading/loadingScreen.js";
import "@babylonjs/loaders/glTF/2.0/index.js";
import { makeCanvas, median, packRgb } from "./common.js";

// The sidecar's rotation: radiance from world d is the map's at R_y(-theta) d. Babylon looks a cube texture up
// at its reflection matrix times d, and Matrix.RotationY(a) (row-major, built for row vectors) acts there as
// R_y(-a) on the right-handed world: rotationY = -theta. Measured by the orientation test (+theta moves the marks).
const ROTATION_SIGN = -1;
// HDRCubeTexture's panorama-to-cube conversion puts the map a quarter turn away from three.js's equirectUv (the
// glTF viewers' convention of the export); measured by the orientation test, undone here as a rotation about +Y.
const PANORAMA_TURN = Math.PI / 2;
// Babylon turns the panorama into cube faces on the CPU by nearest texel, with the texel centred at c / W rather
// than (c + 0.5) / W (Misc/HighDynamicRange/panoramaToCubemap.js: Math.round(u * W)); the skybox gets four times
// the finer faces so that magnified backgrounds are less blocky (the half-texel offset stays).
const SKY_FACE_SCALE = 4;

function loadHdrCube(url, scene, size, prefilter) {
  return new Promise((ok, fail) => {
    const tex = new HDRCubeTexture(url, scene, size, !prefilter, prefilter, false, prefilter,
      () => ok(tex), (msg, e) => fail(new Error(`HDRCubeTexture ${url}: ${msg ?? e}`)));
  });
}

export async function render(cfg) {
  const { width: W, height: H } = cfg;
  const { gl, renderer: glRenderer } = makeCanvas(W, H);
  const t0 = performance.now();
  const engine = new Engine(gl, false, { antialias: false, preserveDrawingBuffer: true, stencil: true, premultipliedAlpha: false }, false);
  engine.setHardwareScalingLevel(1);
  const scene = new Scene(engine);
  scene.useRightHandedSystem = true;
  scene.clearColor = new Color4(0, 0, 0, 1);
  // Babylon's materials always end in applyImageProcessing (gamma encode, saturate) unless image processing is
  // "applied by a post-process" (ImageProcessingConfiguration.prepareDefines: IMAGEPROCESSINGPOSTPROCESS =
  // applyByPostProcess && isEnabled); then they write linear radiance, clamped to [0, 30] unless
  // skipFinalColorClamp. No such post-process is attached here, so nothing is applied after them.
  const ip = scene.imageProcessingConfiguration;
  ip.isEnabled = true;
  ip.applyByPostProcess = true;
  ip.skipFinalColorClamp = true;
  ip.toneMappingEnabled = false;
  ip.exposure = 1.0;
  ip.contrast = 1.0;
  ip.ditheringEnabled = false;
  ip.vignetteEnabled = false;
  ip.colorCurvesEnabled = false;
  ip.colorGradingEnabled = false;
  await AppendSceneAsync(`/scene/${cfg.gltf}`, scene);
  const loadMs = performance.now() - t0;

  // the cube face: a power of two near the map's height / 2 (a quarter turn of the map per face)
  const envHeight = cfg.environment.height;
  const face = Math.min(1024, Math.max(32, 2 ** Math.round(Math.log2(envHeight / 2))));
  const theta = (ROTATION_SIGN * cfg.environment.rotationYDeg * Math.PI) / 180 + PANORAMA_TURN;
  const p0 = performance.now();
  const env = await loadHdrCube(`/scene/${cfg.environment.file}`, scene, face, true);
  const precomputeMs = performance.now() - p0;
  const sky = await loadHdrCube(`/scene/${cfg.environment.file}`, scene, Math.min(2048, SKY_FACE_SCALE * face), false);
  env.rotationY = theta;
  sky.rotationY = theta;
  // the intensity once, on the textures (scene.environmentIntensity would multiply the lighting a second time)
  env.level = cfg.environment.intensity;
  sky.level = cfg.environment.intensity;
  scene.environmentTexture = env;
  scene.environmentIntensity = 1.0;

  // the skybox as createDefaultSkybox(texture, pbr = true) builds it: a PBR material without lighting shows its
  // reflection texture in SKYBOX_MODE linearly (a StandardMaterial would encode it to gamma space and clamp it)
  const skyMaterial = new PBRMaterial("iblcheck-sky", scene);
  skyMaterial.backFaceCulling = false;
  skyMaterial.disableLighting = true;
  skyMaterial.twoSidedLighting = true;
  skyMaterial.microSurface = 1.0;
  sky.coordinatesMode = Texture.SKYBOX_MODE;
  skyMaterial.reflectionTexture = sky;
  const c = cfg.camera;
  // half the far plane: its corners (sqrt(3)/2 far) stay inside the frustum's depth range
  const skybox = CreateBox("iblcheck-sky", { size: c.far }, scene);
  skybox.material = skyMaterial;
  skybox.infiniteDistance = true;
  skybox.isPickable = false;

  const camera = new FreeCamera("iblcheck-camera", new Vector3(...c.position), scene);
  camera.upVector = new Vector3(...c.up);
  camera.setTarget(new Vector3(...c.target));
  camera.fovMode = Camera.FOVMODE_VERTICAL_FIXED;
  camera.fov = c.yfov;
  camera.minZ = c.near;
  camera.maxZ = c.far;
  scene.activeCamera = camera;

  const target = new RenderTargetTexture("iblcheck-out", { width: W, height: H }, scene, {
    generateMipMaps: false, type: Constants.TEXTURETYPE_FLOAT, format: Constants.TEXTUREFORMAT_RGBA,
    samplingMode: Constants.TEXTURE_NEAREST_SAMPLINGMODE, generateDepthBuffer: true, generateStencilBuffer: false,
  });
  camera.outputRenderTarget = target;
  const r0 = performance.now();
  await scene.whenReadyAsync();
  const readyMs = performance.now() - r0;

  const one = new Float32Array(4);
  const finish = async () => { await target.readPixels(0, 0, one, true, false, 0, 0, 1, 1); };
  const f0 = performance.now();
  scene.render();
  await finish();
  const firstFrameMs = performance.now() - f0;
  const frameMs = [];
  for (let i = 0; i < cfg.warmup + cfg.frames; i++) {
    const t = performance.now();
    scene.render();
    await finish();
    if (i >= cfg.warmup) frameMs.push(performance.now() - t);
  }
  const rgba = await target.readPixels(0, 0, null, true, false);
  if (!(rgba instanceof Float32Array) || rgba.length < W * H * 4) throw new Error(`the float render target read back as ${rgba?.constructor?.name} of ${rgba?.length}`);
  const materials = [...new Set(scene.meshes.map((m) => m.material?.getClassName()).filter(Boolean))].join(", ");
  return {
    width: W, height: H, rgb: packRgb(rgba, W, H),
    engine: "Babylon.js", version: Engine.Version,
    frame_ms: frameMs, precompute_ms: precomputeMs, load_ms: loadMs, first_frame_ms: firstFrameMs, ready_ms: readyMs,
    median_frame_ms: median(frameMs),
    notes: `WebGL: ${glRenderer}; materials: ${materials}; environment: HDRCubeTexture of face ${face} ` +
      "with Babylon's GGX prefiltering (precompute_ms: the HDR decode, the CPU equirect-to-cube conversion and the " +
      "prefiltering), diffuse from spherical harmonics; right-handed scene; image processing deferred to a post-process never attached (linear, unclamped); " +
      "background: a skybox of the unfiltered cube; ready_ms: scene.whenReadyAsync (shader compilation)",
  };
}
