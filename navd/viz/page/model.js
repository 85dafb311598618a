// What the page knows (from navd's live view) and how it looks at the map: shared by the
// stream, the picture, the panel and the controls.

// The latest of each channel, and whether the live view's WebSocket is open.
export const state = {
  info: null, map: null, pose: null, scans: {}, route: null, goal: null,
  status: null, goalStatus: null, connected: false,
};

// px per m, and the map point at the centre; the view follows the growing map until the
// person zooms
export const view = { scale: 50, cx: 0, cy: 0, zoomed: false };

// A press on the map in progress (its start and where it is now, in px), or null; and
// whether a two-finger gesture is under way (nothing is sent until every finger lifts).
export const pointer = { press: null, gesture: false };
