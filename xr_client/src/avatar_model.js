// @ts-check
/**
 * The operators of a replayed session (docs/study.md): each one's latest `avatar` (where they looked from, and their
 * hands), kept while the replay is near its time, as scene poses the avatar view draws. No DOM, no WebGL:
 * test/avatar_model.test.js drives it.
 */
import { poseToScene } from './viewer_pose.js';

/**
 * An avatar older (or newer) than this in the recording's time than what the replay shows now is gone: its operator
 * left, or a seek moved the replay away from it (s). Pages send their viewpoint 4 times a second.
 */
export const AVATAR_STALE_S = 2;

/**
 * @typedef {import('./protocol.js').AvatarMessage} AvatarMessage
 * @typedef {{client: string, label: string, head: import('./viewer_pose.js').ScenePose,
 *   hands: import('./viewer_pose.js').SceneHand[]}} AvatarFigure an operator as drawn: scene poses
 */

export class AvatarModel {
  /** Each operator's latest viewpoint, by client id. @type {Map<string, AvatarMessage>} */
  avatars = new Map();
  /** The recording's time the replay shows now (s since the epoch): the stamp of its latest pose or avatar. */
  now = -Infinity;

  /**
   * An `avatar` message; nothing for the router to carry out (the view reads the model).
   * @param {AvatarMessage} message
   */
  apply(message) {
    this.avatars.set(message.client, message);
    this.at(message.stamp);
    return [];
  }

  /**
   * The replay showed something recorded at `stamp` (s since the epoch): avatars far from it go.
   * @param {number} stamp
   */
  at(stamp) {
    this.now = stamp;
    for (const [client, avatar] of this.avatars)
      if (Math.abs(avatar.stamp - stamp) > AVATAR_STALE_S) this.avatars.delete(client);
  }

  clear() {
    this.avatars.clear();
    this.now = -Infinity;
  }

  /**
   * Every operator in the scene, labelled by name (else client id).
   * @param {import('./frames.js').MapToScene} t @returns {AvatarFigure[]}
   */
  figures(t) {
    /** @type {AvatarFigure[]} */
    const figures = [];
    for (const avatar of this.avatars.values()) {
      const head = poseToScene(t, avatar.head.position, avatar.head.look);
      if (!head) continue;
      /** @type {import('./viewer_pose.js').SceneHand[]} */
      const hands = [];
      for (const hand of avatar.hands) {
        const pose = poseToScene(t, hand.position, hand.ray);
        if (pose) hands.push({ hand: hand.hand, ...pose });
      }
      figures.push({ client: avatar.client, label: avatar.name ?? avatar.client, head, hands });
    }
    return figures;
  }
}
