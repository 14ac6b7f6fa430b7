// @ts-check
/**
 * One configured GLTFLoader for the twin and the robots, with every decoder served locally by the relay
 * (Draco, meshopt, KTX2 from three's own package): nothing is fetched from the Internet.
 */
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { DRACOLoader } from 'three/addons/loaders/DRACOLoader.js';
import { KTX2Loader } from 'three/addons/loaders/KTX2Loader.js';
import { MeshoptDecoder } from 'three/addons/libs/meshopt_decoder.module.js';
import { disposeModel } from './model_materials.js';

const LIBS = '/node_modules/three/examples/jsm/libs/';

export class ModelLoader {
  /** @param {import('three').WebGLRenderer} renderer */
  constructor(renderer) {
    this.draco = new DRACOLoader().setDecoderPath(`${LIBS}draco/gltf/`);
    this.ktx2 = new KTX2Loader().setTranscoderPath(`${LIBS}basis/`).detectSupport(renderer);
    this.loader = new GLTFLoader()
      .setDRACOLoader(this.draco)
      .setKTX2Loader(this.ktx2)
      .setMeshoptDecoder(MeshoptDecoder);
    /** @type {Map<string, Promise<import('three/addons/loaders/GLTFLoader.js').GLTF>>} */
    this.cache = new Map();
  }

  /**
   * A glTF, loaded once per URL (robots share their model). Callers clone what they add to the scene.
   * @param {string} url
   */
  load(url) {
    let promise = this.cache.get(url);
    if (!promise) {
      promise = this.loader.loadAsync(url);
      promise.catch(() => this.cache.delete(url));
      this.cache.set(url, promise);
    }
    return promise;
  }

  /**
   * Forget a model and free what it holds on the GPU: a twin replaced by another (a newer live map) would
   * otherwise stay in memory for the life of the page. Clones of it must no longer be shown.
   * @param {string} url
   */
  release(url) {
    const promise = this.cache.get(url);
    if (!promise) return;
    this.cache.delete(url);
    promise.then(
      (gltf) => disposeModel(gltf.scene),
      () => {},
    );
  }

  dispose() {
    for (const url of [...this.cache.keys()]) this.release(url);
    this.draco.dispose();
    this.ktx2.dispose();
    this.cache.clear();
  }
}
