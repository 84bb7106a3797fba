// three.js: the exported glTF under the exported equirect map, rendered into a float render target and read
// back as linear radiance (no tone mapping, no output colour-space conversion, no anti-aliasing).
//   environment: HDRLoader as a float texture with EquirectangularReflectionMapping; three's own PMREM
//     (PMREMGenerator.fromEquirectangular, what scene.environment does implicitly) is run here so it is timed
//     apart; the background is the equirect texture itself (three turns it into a cube at the first frame).
//   rotation: three looks maps up at transpose(R(environmentRotation)) d (WebGLMaterials.js, WebGLBackground.js),
//     so environmentRotation.y = +theta gives the sidecar's "radiance from d is the map's at R_y(-theta) d".
//   camera: built from the sidecar (position, target, up, vertical fov, near, far) with aspect W/H; three's
//     lookAt is gluLookAt's frame.
import * as THREE from "three";
import { GLTFLoader } from "three/addons/loaders/GLTFLoader.js";
import { HDRLoader } from "three/addons/loaders/HDRLoader.js";
import { makeCanvas, median, packRgb, timeFrames } from "./common.js";

export async function render(cfg) {
  const { width: W, height: H } = cfg;
  const { canvas, gl, renderer: glRenderer } = makeCanvas(W, H);
  const t0 = performance.now();
  const renderer = new THREE.WebGLRenderer({ canvas, context: gl, antialias: false });
  renderer.setPixelRatio(1);
  renderer.setSize(W, H, false);
  renderer.toneMapping = THREE.NoToneMapping;
  renderer.toneMappingExposure = 1.0;
  renderer.outputColorSpace = THREE.LinearSRGBColorSpace;

  // float textures are only filterable with OES_texture_float_linear; half floats always are
  const floatLinear = !!gl.getExtension("OES_texture_float_linear");
  const hdr = await new HDRLoader()
    .setDataType(floatLinear ? THREE.FloatType : THREE.HalfFloatType)
    .loadAsync(`/scene/${cfg.environment.file}`);
  hdr.mapping = THREE.EquirectangularReflectionMapping;
  hdr.colorSpace = THREE.LinearSRGBColorSpace;
  const gltf = await new GLTFLoader().loadAsync(`/scene/${cfg.gltf}`);
  const loadMs = performance.now() - t0;

  const scene = new THREE.Scene();
  scene.add(gltf.scene);
  const theta = THREE.MathUtils.degToRad(cfg.environment.rotationYDeg);
  scene.environmentRotation.set(0, theta, 0);
  scene.backgroundRotation.set(0, theta, 0);
  scene.environmentIntensity = cfg.environment.intensity;
  scene.backgroundIntensity = cfg.environment.intensity;
  scene.background = hdr;

  const c = cfg.camera;
  const camera = new THREE.PerspectiveCamera(THREE.MathUtils.radToDeg(c.yfov), W / H, c.near, c.far);
  camera.position.set(...c.position);
  camera.up.set(...c.up);
  camera.lookAt(new THREE.Vector3(...c.target));
  camera.updateProjectionMatrix();
  camera.updateMatrixWorld(true);

  const target = new THREE.WebGLRenderTarget(W, H, {
    type: THREE.FloatType, format: THREE.RGBAFormat, minFilter: THREE.NearestFilter, magFilter: THREE.NearestFilter,
    generateMipmaps: false, depthBuffer: true, samples: 0, colorSpace: THREE.LinearSRGBColorSpace,
  });
  const one = new Float32Array(4);
  const finish = () => renderer.readRenderTargetPixels(target, 0, 0, 1, 1, one);

  const p0 = performance.now();
  const pmrem = new THREE.PMREMGenerator(renderer);
  const prefiltered = pmrem.fromEquirectangular(hdr);
  renderer.setRenderTarget(target);
  finish();
  const precomputeMs = performance.now() - p0;
  scene.environment = prefiltered.texture;

  renderer.setRenderTarget(target);
  const f0 = performance.now();
  renderer.render(scene, camera);
  finish();
  const firstFrameMs = performance.now() - f0;
  const frameMs = await timeFrames(() => renderer.render(scene, camera), finish, cfg.warmup, cfg.frames);

  const rgba = new Float32Array(W * H * 4);
  renderer.readRenderTargetPixels(target, 0, 0, W, H, rgba);
  return {
    width: W, height: H, rgb: packRgb(rgba, W, H),
    engine: "three.js", version: `0.${THREE.REVISION}.0`, revision: THREE.REVISION,
    frame_ms: frameMs, precompute_ms: precomputeMs, load_ms: loadMs, first_frame_ms: firstFrameMs,
    median_frame_ms: median(frameMs),
    notes: `WebGL: ${glRenderer}; environment texture ${floatLinear ? "float32" : "half float (no OES_texture_float_linear)"}; ` +
      "PMREM: three's PMREMGenerator (cube-UV, GGX-filtered mips); MeshStandardMaterial/MeshPhysicalMaterial from GLTFLoader " +
      "(three adds multiple-scattering energy compensation to image-based specular); background: the equirect map through " +
      "three's cube conversion; precompute_ms is the PMREM; first_frame_ms includes shader compilation and the background cube",
  };
}
