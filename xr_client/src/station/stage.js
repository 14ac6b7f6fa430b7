// @ts-check
/**
 * The three.js stage the station draws on: the renderer (set up for WebXR), the lights, the operator's rig and
 * camera, the world the twin and the robots live in, what reads that world (picking, the twin's plan for where VR
 * starts) and the XR session that moves the rig. The App builds it first; the views are added to it.
 */
import * as THREE from 'three';
import { ModelLoader } from '../view/gltf_loading.js';
import { TwinView } from '../view/twin_view.js';
import { FleetView } from '../view/fleet_view.js';
import { XRSessionController } from '../view/xr_session.js';
import { Picking } from '../view/picking.js';
import { TwinPlan } from '../view/twin_plan.js';
import { VoxelView } from '../view/voxel_view.js';

export class Stage {
  /**
   * @param {HTMLElement} container where the canvas goes
   * @param {{lowQuality?: boolean, detailedMax?: number}} options lowQuality: no multisampling, a lower
   *   resolution; detailedMax: robots drawn with their full model at most (render_quality.js)
   * @param {{fleet: import('../fleet_model.js').FleetModel, menu: import('../menu_state.js').MenuState,
   *   voxels: import('../voxel_map.js').VoxelMapModel, onError: (text: string) => void}} host what the picking, the XR
   *   session and the 3D map read, and where their errors go
   */
  constructor(container, options, host) {
    this.container = container;
    this.renderer = new THREE.WebGLRenderer({ antialias: !options.lowQuality, powerPreference: 'high-performance' });
    this.renderer.setPixelRatio(options.lowQuality ? 0.75 : Math.min(window.devicePixelRatio, 2));
    this.renderer.setSize(container.clientWidth, container.clientHeight);
    this.renderer.xr.enabled = true;
    this.renderer.xr.setReferenceSpaceType('local-floor');
    this.renderer.xr.setFoveation(0.5);
    container.append(this.renderer.domElement);
    this.scene = new THREE.Scene();
    this.scene.background = new THREE.Color('#161b24');
    this.scene.add(new THREE.HemisphereLight('#dfe8ff', '#3a3f4a', 2.2));
    const sun = new THREE.DirectionalLight('#ffffff', 1.6);
    sun.position.set(5, 10, 4);
    this.scene.add(sun);
    /** The operator: the camera and the XR controllers ride on it; locomotion moves it. */
    this.rig = new THREE.Group();
    this.rig.name = 'rig';
    this.scene.add(this.rig);
    this.camera = new THREE.PerspectiveCamera(60, container.clientWidth / container.clientHeight, 0.05, 300);
    this.rig.add(this.camera);
    /** Everything of the twin: hidden in Robot POV's neutral space. */
    this.world = new THREE.Group();
    this.world.name = 'world';
    this.scene.add(this.world);
    this.loader = new ModelLoader(this.renderer);
    this.twin = new TwinView(this.loader);
    this.world.add(this.twin.group);
    this.fleetView = new FleetView(this.world, this.loader, this.renderer, options.detailedMax);
    this.robotViews = this.fleetView.views;
    /** The live 3D map (issue #33), in the world beside the twin. */
    this.voxels = new VoxelView(host.voxels, () => host.fleet.scene.mapToScene);
    this.world.add(this.voxels.group);
    this.picking = new Picking(this.twin, this.robotViews, host.fleet, this.voxels);
    const plan = new TwinPlan(this.twin, this.picking, host.fleet);
    this.xrSession = new XRSessionController(
      this.renderer,
      this.rig,
      this.camera,
      { fleet: host.fleet, menu: host.menu, plan },
      host.onError,
    );
  }

  /** Whether the headset shows the stage (else the desktop page does). */
  get presenting() {
    return this.renderer.xr.isPresenting;
  }

  /** The camera follows the container's shape; in VR the session sizes the drawing itself. */
  resize() {
    const w = this.container.clientWidth;
    const h = this.container.clientHeight;
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
    if (!this.presenting) this.renderer.setSize(w, h);
  }

  /** The XR session ends; the fleet, the twin, the models and the renderer are released, the canvas removed. */
  dispose() {
    this.xrSession.dispose();
    this.fleetView.dispose();
    this.twin.dispose();
    this.voxels.dispose();
    this.loader.dispose();
    this.renderer.dispose();
    this.renderer.domElement.remove();
  }
}
