// @ts-check
/**
 * The read-only snapshot of the client behind `window.__xrRelay.state`: what the end-to-end tests wait on
 * (menu, selection, rig pose, goal pointer, teleop, Robot POV uploads, video decoding, frame timing) and what a
 * developer reads in a console. Building it changes nothing.
 */
import { smallestFont } from '../label_rule.js';
import * as THREE from 'three';
import { mapToScene, sceneYawToMap } from '../frames.js';

/** @param {import('../app.js').App} app */
export function snapshotState(app) {
  const rigQuaternion = app.stage.rig.getWorldQuaternion(new THREE.Quaternion());
  const { hemisphere, interaction } = app.views;
  const menu = app.menu;
  const decoder = app.views.feed.jpeg;
  const groupBar = app.views.overlay.groupBar;
  return {
    connected: app.relay.linkOk,
    // When the relay's last pong was read (performance.now() ms): what the link's liveness is judged on (reconnect.js).
    pongAt: app.connection.policy.lastPong,
    link: app.relay.linkText,
    // A replay's position as the page shows it, and its operators drawn (view/avatar_view.js, view/playback_bar.js).
    playback: app.router.playback,
    replay: {
      bar: !app.views.playbackBar.bar.hidden,
      avatars: [...app.views.avatars.figures].filter(([, f]) => f.group.visible).map(([client]) => client),
    },
    // The desktop menu's groups of robots (each team, each room with robots in it) and the one chosen.
    groups: { list: groupBar.groups.map((g) => ({ id: g.id, robots: g.robots })), chosen: groupBar.chosenId },
    // Each arm's newest joint positions, and whether it is drawn on its robot (view/arm_view.js).
    arms: Object.fromEntries(
      [...app.router.arms.joints].map(([robot, joints]) => [
        robot,
        {
          positions: joints.positions,
          drawn: app.views.arms.views.get(robot)?.group.parent != null,
          // Where the gripper is drawn (world), and whether a hand holds the arm (VR).
          tip: app.views.arms.views.get(robot)?.balls.at(-1)?.getWorldPosition(new THREE.Vector3()).toArray() ?? null,
          held: app.views.armGrab.grab.held !== null && app.menu.selected === robot,
          // The hand's scale on it, and why its last motion was refused while that is shown (VR).
          scale: app.views.armGrab.grab.scale,
          refusal: app.router.arms.refusal(robot, performance.now()),
          // The gripper's camera beside it while held (VR): shown, its frames' identifier, pictures shown.
          gripperCamera: app.menu.selected === robot ? app.views.armGrab.gripperCamera.state() : null,
        },
      ]),
    ),
    // The study the relay runs (study_model.js): where it is, and the answers being given.
    study: app.router.study.message && {
      phase: app.router.study.message.phase,
      participant: app.router.study.message.participant,
      condition: app.router.study.message.condition,
      task: app.router.study.message.task,
      questionnaire: app.router.study.message.questionnaire,
      done: app.router.study.message.done,
      sus: app.router.study.sus,
      tlx: app.router.study.tlx,
      item: app.router.study.item, // the SUS item or TLX scale the VR menu asks
    },
    // The facility's valve wheel as reported, and where it is drawn (world; view/valve_view.js).
    valve: app.router.arms.valve && {
      angle: app.router.arms.valve.angle,
      held: app.router.arms.valve.held,
      shut: app.router.arms.valve.shut,
      drawn: app.views.valve.group.visible && app.views.valve.group.parent != null,
      turned: app.views.valve.spin.rotation.x,
      centre: app.views.valve.group.getWorldPosition(new THREE.Vector3()).toArray(),
    },
    inspection: {
      targets: app.views.inspectionUi.model.targets.size,
      missions: Object.fromEntries([...app.views.inspectionUi.model.missions.values()].map((m) => [m.robot, m.state])),
      findings: app.views.inspectionUi.model
        .list()
        .map((f) => ({ id: f.id, target: f.target, status: f.status, region: f.region !== null, x: f.x, y: f.y })),
      owners: Object.fromEntries([...app.views.inspectionUi.model.missions.values()].map((m) => [m.id, m.owner])),
      schedules: app.views.inspectionUi.model.schedules.map((s) => ({
        schedule: s.schedule,
        repeat: s.repeat,
        last: s.last_run?.outcome ?? null,
        mission: s.last_run?.mission ?? null,
      })),
      scheduleForm: app.views.inspectionUi.scheduleForm
        ? {
            visible: app.views.inspectionUi.scheduleForm.visible,
            open: app.views.inspectionUi.scheduleForm.editor.open,
            editing: app.views.inspectionUi.scheduleForm.editor.before?.schedule ?? null,
            pending: app.views.inspectionUi.scheduleForm.editor.pending !== null,
            error: app.views.inspectionUi.scheduleForm.editor.error,
            field: app.views.inspectionUi.scheduleForm.editor.field,
          }
        : null,
      pins: app.views.inspectionUi.view.group.children.filter((c) => c.name.startsWith('finding:')).length,
      // Each drawn pin's colour and label by finding id (change_colour.js), and whether only changes show.
      pinLooks: { ...app.views.inspectionUi.view.pins },
      sinceLastRound: app.views.inspectionUi.model.sinceLastRound,
      picked: [...app.views.inspectionUi.review.picked],
      review: {
        selected: app.views.inspectionUi.review.selected,
        pending: app.views.inspectionUi.review.pending !== null,
        proposal: app.views.inspectionUi.review.proposal !== null,
        imageAction: app.views.inspectionUi.review.imageAction,
      },
      card: {
        visible: app.views.findingCard.mesh.visible,
        image: app.views.findingCard.imageSize,
        // A changed finding's images on the VR card: which shows, and whether its before image has loaded.
        showing: app.views.findingCard.showing,
        before: app.views.findingCard.before.state,
        draws: app.views.findingCard.draws,
        // The note read on the VR card: the lines drawn, and whether a phrase is being dictated.
        note: app.views.findingCard.reading ? app.views.findingCard.noteLines : null,
        dictation: app.views.dictation.state,
        wipe: app.views.inspectionUi.panel?.wipe ?? null, // the desktop card's before/after slider (0-100)
      },
    },
    clientId: app.fleet.clientId,
    presenting: app.presenting,
    vr: app.vr,
    menu: {
      open: menu.open,
      mode: menu.mode,
      selected: menu.selected,
      tool: menu.tool,
      live: menu.live,
      buttons: menu.buttons(),
      centres: app.presenting && menu.open ? app.views.menuPanel.buttonCentres() : {},
      tab: app.views.menuPanel.tab.visible
        ? app.views.menuPanel.tab.getWorldPosition(new THREE.Vector3()).toArray()
        : null,
    },
    xr: {
      hover: app.presenting ? interaction.hovered() : {},
      vignette: app.views.vignette.strength,
      haptics: { ...app.views.xrInput.felt }, // the pulses a controller's actuator was given, and the last
      teleport:
        interaction.motion.teleport.aiming || interaction.motion.pinchTeleport
          ? (interaction.motion.teleportHit?.toArray() ?? 'no floor')
          : null,
    },
    estop: {
      latched: [...menu.latched],
      banner: app.views.overlay.banner?.text ?? null,
      fleet: app.views.overlay.banner?.fleet ?? false,
      page: !document.getElementById('estop-banner')?.hidden,
      vr: app.views.hud.estop.banner.sprite.visible,
      wrist: app.views.hud.estop.button.mesh.parent !== null,
      /** The wrist E-STOP is drawn: it and what carries it are visible (a controller's grip, a hand's grip pose). */
      wristDrawn: app.presenting && shown(app.views.hud.estop.button.mesh),
      points:
        app.presenting && app.views.hud.estop.button.mesh.parent
          ? { wrist: app.views.hud.estop.button.mesh.getWorldPosition(new THREE.Vector3()).toArray() }
          : {},
    },
    camera: app.stage.camera.position.toArray(),
    eye: app.stage.camera.getWorldPosition(new THREE.Vector3()).toArray(),
    view: viewState(app),
    panel: panelState(app),
    overview: {
      visible: app.views.hud.miniature.group.visible,
      cursor: app.views.interaction.goals.wimCursor,
      arrows: app.views.hud.miniature.robots.size,
      scale: app.views.hud.miniature.scale,
      position: app.views.hud.miniature.group.position.toArray(),
      radius: app.views.hud.miniature.table.scale.x,
      /** Voxels of the 3D map drawn on the table, and whether the twin's copy shows there. */
      voxels: app.views.hud.miniature.mapMirror?.count ?? 0,
      twin: app.views.hud.miniature.copy?.visible ?? false,
    },
    /** Where VR started (map frame; start_pose.js), and what it saw from there. */
    start: app.stage.xrSession.plan.last,
    paths: Object.fromEntries(
      [...app.views.goalView.paths]
        .filter(([, p]) => p.line.visible)
        .map(([robot, p]) => [robot, p.source?.length ?? 0]),
    ),
    markers: Object.fromEntries([...app.views.goalView.markers].map(([robot, m]) => [robot, m.group.visible])),
    rig: {
      position: app.stage.rig.position.toArray(),
      quaternion: rigQuaternion.toArray(),
      yaw: app.stage.rig.rotation.y,
    },
    world: app.stage.world.visible,
    voxels: {
      version: app.router.voxels.version,
      held: app.router.voxels.count,
      drawn: app.stage.voxels.drawn,
      visible: app.stage.voxels.group.visible,
      twin: app.stage.twin.group.visible,
    },
    labels: {
      capacity: app.stage.fleetView.atlas.layout.capacity,
      whole: app.stage.fleetView.atlas.uploads.whole,
      cells: app.stage.fleetView.atlas.uploads.cells,
      scans: app.stage.fleetView.scans.drawn,
    },
    map: {
      rooms: app.stage.fleetView.annotations.rooms,
      grid: app.stage.fleetView.annotations.gridLines,
      north: app.stage.fleetView.annotations.north,
    },
    robots: Object.fromEntries(
      [...app.stage.robotViews].map(([name, v]) => [
        name,
        {
          position: v.group.position.toArray(),
          visible: v.group.visible,
          controller: app.fleet.robot(name)?.status?.controller ?? null,
          offline: v.offline,
          stale: v.stale,
          label: v.label.key,
          warning: v.warning.sprite.visible,
          scan: { points: v.scanCount, visible: v.scanVisible },
          // Heading: the footprint arrow's direction in the map frame (rad, CCW from east); label: its height (m) and
          // on the desktop page (px).
          heading: headingOf(app, v),
          detailed: v.detailed,
          ...labelState(app, v),
        },
      ]),
    ),
    goal: {
      pointer: app.goalPointer.state,
      hover: app.goalPointer.hover,
      marker: app.goalPointer.marker,
      verdict: app.goalPointer.verdict,
      colour: `#${app.views.goalView.pointer.material.color.getHexString()}`,
      sent: app.sender.counts.goals,
    },
    teleop: {
      robot: app.teleop.robot,
      source: app.teleop.source,
      driving: app.teleop.driving,
      sent: app.teleop.sent,
      last: app.teleop.lastCommand,
      // Where the socket and the 20 Hz clock run (a worker, or this page without one); stops the worker made.
      worker: app.connection.link !== null && !app.connection.link.failed,
      workerClock: app.driver.workerClock,
      expiries: app.driver.expiries,
    },
    commands: { ...app.sender.counts },
    twin: {
      state: app.stage.twin.state,
      url: app.stage.twin.url ?? null,
      floor: app.stage.twin.floorTargets.map((o) => o.name),
    },
    pov: {
      visible: hemisphere.group.visible,
      uploads: hemisphere.uploads,
      decoded: decoder.decoded,
      received: decoder.received,
      dropped: decoder.queue.dropped,
      lastSeq: hemisphere.lastSeq,
      identifier: hemisphere.lastIdentifier,
      textureUuid: hemisphere.texture.uuid,
      textureSize: [hemisphere.width, hemisphere.height],
      mipmaps: hemisphere.texture.generateMipmaps,
      snapshots: { ...app.sender.snapshots },
    },
    // The live stream's codec and the H.264 decoder's counts (view/camera_feed.js, video_decoder.js).
    video: app.views.feed.state(),
    // What the robot card and the POV show of each robot's latency (latency.js), and the clock mapping's error.
    latency: {
      robots: Object.fromEntries([...app.fleet.robots.keys()].map((r) => [r, app.latency.of(r)])),
      clockError: app.latency.clock.error,
      shown: app.views.overlay.sensorCanvas.dataset.latency ?? '',
    },
    voice: { ...app.views.voice.state(), toast: app.views.hud.toast.sprite.visible },
    /** The message line (and, in VR, the HUD's toast) says this now. */
    notice: app.views.overlay.message.textContent,
    sound: app.views.sound.state(),
    hands: app.views.interaction.handInput.state(),
    gaze: { ...app.views.interaction.gazeDwell.gaze },
    timing: {
      renders: app.loop.renders,
      frames: app.loop.frameCount,
      recent: app.loop.frameTimer.recent(120),
      ...app.loop.frameTimer.stats(),
    },
    textures: app.stage.renderer.info.memory.textures,
    draw: {
      calls: app.stage.renderer.info.render.calls,
      triangles: app.stage.renderer.info.render.triangles,
      pixelRatio: app.stage.renderer.getPixelRatio(),
      maxFps: app.loop.minFrameMs ? 1000 / app.loop.minFrameMs : null,
      detailedMax: app.stage.fleetView.detailedMax,
    },
  };
}

/**
 * What the sensor panels show: each reading, whether it is old (and how old), and the gaps in its sparkline.
 * @param {import('../app.js').App} app
 */
function panelState(app) {
  const data = app.sensorPanelData(performance.now());
  const robot = data.robot;
  return {
    robot,
    sensors: data.sensors.map((x) => {
      const values = robot ? app.history.values(robot, x.name).v : [];
      const line = robot
        ? app.history.sparkline(robot, x.name, data.now, 100, 40, { above: x.above, below: x.below })
        : null;
      return {
        name: x.name,
        value: x.value,
        stale: x.stale ?? null,
        gaps: robot ? app.history.breaks(robot, x.name).length : 0,
        lowest: values.length ? Math.min(...values) : null,
        thresholds: line?.lines.length ?? 0,
        spread:
          line && line.points.length
            ? Math.max(...line.points.map((p) => p[1])) - Math.min(...line.points.map((p) => p[1]))
            : 0,
      };
    }),
  };
}

/**
 * Where a map point (ROS, metres) appears on the desktop page, in CSS pixels (tests click there).
 * @param {import('../app.js').App} app @param {number} x @param {number} y @param {number} [z]
 * @returns {[number, number]}
 */
export function mapToPage(app, x, y, z = 0) {
  const v = new THREE.Vector3(...mapToScene(app.fleet.scene.mapToScene, x, y, z)).project(app.stage.camera);
  const rect = app.stage.renderer.domElement.getBoundingClientRect();
  return [rect.left + ((v.x + 1) / 2) * rect.width, rect.top + ((1 - v.y) / 2) * rect.height];
}

/**
 * The footprint arrow's direction in the map frame (rad, CCW from east). @param {import('../app.js').App} app
 * @param {import('./robot_view.js').RobotView} view
 */
function headingOf(app, view) {
  const d = new THREE.Vector3(1, 0, 0).transformDirection(view.heading.matrixWorld);
  return sceneYawToMap(app.fleet.scene.mapToScene, Math.atan2(-d.z, d.x));
}

/**
 * A robot's label: its height (m), opacity, lines; on the desktop page its height (px) and smallest font (px, its
 * status lines': label_rule.js smallestFont); where it is (x0, y0, x1, y1 px on the desktop's page, in VR on the left
 * eye's picture) and whether another covers it (a ghost).
 * @param {import('../app.js').App} app @param {import('./robot_view.js').RobotView} view
 */
function labelState(app, view) {
  const fleetView = app.stage.fleetView;
  const pixels = app.presenting ? null : labelPixels(app, view);
  return {
    labelHeight: view.label.sprite.scale.y,
    labelOpacity: fleetView.atlas.opacities.getX(view.index),
    labelLines: view.labelLines,
    labelPixels: pixels,
    labelFont: pixels === null ? null : smallestFont(pixels, view.labelLines),
    labelRect: [...fleetView.labelRects.slice(4 * view.index, 4 * view.index + 4)],
    labelGhost: fleetView.uncovered[view.index] < 1,
  };
}

/**
 * How tall a robot's label is on the desktop page (px): the sprite faces the camera.
 * @param {import('../app.js').App} app @param {import('./robot_view.js').RobotView} view
 */
function labelPixels(app, view) {
  const sprite = view.label.sprite;
  const anchor = sprite.getWorldPosition(new THREE.Vector3());
  const up = new THREE.Vector3(0, sprite.scale.y, 0).applyQuaternion(
    app.stage.camera.getWorldQuaternion(new THREE.Quaternion()),
  );
  const a = anchor.clone().project(app.stage.camera);
  const b = anchor.clone().add(up).project(app.stage.camera);
  const rect = app.stage.renderer.domElement.getBoundingClientRect();
  return Math.hypot(((b.x - a.x) / 2) * rect.width, ((b.y - a.y) / 2) * rect.height);
}

/**
 * The desktop view: its mode, the free part of the window, the compass and scale bar, the panels.
 * @param {import('../app.js').App} app
 */
function viewState(app) {
  const views = app.views.desktop.views;
  return {
    mode: views.mode,
    free: views.free,
    target: views.host.orbit.target.toArray(),
    distance: app.stage.camera.position.distanceTo(views.host.orbit.target),
    polar: views.host.orbit.getPolarAngle(),
    compass: views.mapHud.compass,
    scale: { text: views.mapHud.scale.text, px: views.mapHud.scale.px },
    panels: { ...app.views.overlay.panels.open },
    compact: document.body.classList.contains('compact'),
  };
}

/** Whether an object is drawn: it and every parent visible. @param {THREE.Object3D} object */
function shown(object) {
  for (let o = /** @type {THREE.Object3D | null} */ (object); o; o = o.parent) if (!o.visible) return false;
  return true;
}
