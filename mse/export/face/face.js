// mse face player: evaluates the compiled face rig for the playhead's time and updates the
// SVG paths.  The arithmetic mirrors mse/export/face/rig.py (pose_points, shape_paths) and
// track.py (key_weight, Track.values) line for line, so the page and the video agree.
(function () {
  "use strict";
  var dataNode = document.getElementById("mse-face");
  if (!dataNode) { return; }
  var data = JSON.parse(dataNode.textContent);
  var rig = data.rig;
  var track = data.track;
  var KAPPA = 0.5522847498;
  var TRANSFORMS = 7;
  var channelCount = rig.channels.length;
  var deltaCount = channelCount - TRANSFORMS;
  var svg = document.getElementById("face");
  var paths = Array.prototype.slice.call(svg.querySelectorAll("path.face-shape"));
  var markerBox = document.getElementById("face-markers");

  function smooth(u) {
    u = Math.min(1, Math.max(0, u));
    return u * u * (3 - 2 * u);
  }

  // Saccades: mirrors track.py (SACCADE_FIXATIONS, SACCADE_JUMP, saccades).
  var FIXATIONS = [[1.0, 1.0], [0.7, -0.55], [1.3, 0.25], [0.8, -1.0], [1.2, 0.6], [1.0, -0.2]];
  var JUMP = 0.04;

  function saccades(elapsed, period) {
    var ends = [], total = 0;
    FIXATIONS.forEach(function (f) { total += f[0] * period; ends.push(total); });
    var u = Math.max(elapsed, 0);
    var cycle = Math.floor(u / total);
    var rest = u - cycle * total;
    var index = 0;
    while (index < ends.length - 1 && ends[index] <= rest) { index++; }
    var previous = index === 0 && cycle === 0 ? 0 : FIXATIONS[(index + FIXATIONS.length - 1) % FIXATIONS.length][1];
    var jump = smooth((rest - (ends[index] - FIXATIONS[index][0] * period)) / JUMP);
    return previous + (FIXATIONS[index][1] - previous) * jump;
  }

  function keyWeight(key, t) {
    if (!(t > key.start && t < key.stop)) { return 0; }
    if (key.repeat) {
      var span = key.stop - key.start;
      var count = Math.max(1, Math.round(span / key.repeat[0]));
      var slot = span / count;
      var width = Math.min(key.repeat[1], slot);
      var index = Math.min(count - 1, Math.max(0, Math.floor((t - key.start) / slot)));
      var centre = key.start + (index + 0.5) * slot;
      return smooth(1 - Math.abs(t - centre) / (width / 2));
    }
    var rise = key.attack > 0 ? smooth((t - key.start) / key.attack) : 1;
    var fall = key.release > 0 ? smooth((key.stop - t) / key.release) : 1;
    var weight = Math.min(rise, fall);
    if (key.oscillate && key.oscillate[1] === "saccade") {
      return weight * saccades(t - key.start, key.oscillate[0]);
    }
    if (key.oscillate) {
      var phase = 2 * Math.PI * (t - key.start) / key.oscillate[0];
      weight *= key.oscillate[1] === "sine" ? Math.sin(phase) : (1 - Math.cos(phase)) / 2;
    }
    return weight;
  }

  function channels(t) {
    var values = new Array(channelCount).fill(0);
    track.keys.forEach(function (key) {
      var weight = keyWeight(key, t);
      key.targets.forEach(function (target) { values[target[0]] += weight * target[1]; });
    });
    track.clamped.forEach(function (c) { values[c] = Math.min(1, Math.max(0, values[c])); });
    return values;
  }

  function rotation(yaw, pitch, roll) {
    var r = Math.PI / 180;
    var cy = Math.cos(yaw * r), sy = Math.sin(yaw * r);
    var cp = Math.cos(pitch * r), sp = Math.sin(pitch * r);
    var cr = Math.cos(roll * r), sr = Math.sin(roll * r);
    var a = [[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]];
    var b = [[1, 0, 0], [0, cp, sp], [0, -sp, cp]];
    var c = [[cr, -sr, 0], [sr, cr, 0], [0, 0, 1]];
    return multiply(multiply(a, b), c);
  }

  function multiply(a, b) {
    var m = [[0, 0, 0], [0, 0, 0], [0, 0, 0]];
    for (var i = 0; i < 3; i++) {
      for (var j = 0; j < 3; j++) {
        m[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
      }
    }
    return m;
  }

  function turn(m, p, pivot) {
    var x = p[0] - pivot[0], y = p[1] - pivot[1], z = p[2] - pivot[2];
    return [m[0][0] * x + m[0][1] * y + m[0][2] * z + pivot[0],
            m[1][0] * x + m[1][1] * y + m[1][2] * z + pivot[1],
            m[2][0] * x + m[2][1] * y + m[2][2] * z + pivot[2]];
  }

  function posePoints(values) {
    var points = rig.base.map(function (p) { return [p[0], p[1], p[2]]; });
    for (var c = 0; c < deltaCount; c++) {
      var v = values[c];
      if (v === 0) { continue; }
      rig.deltas[c].forEach(function (row) {
        var p = points[row[0]];
        p[0] += v * row[1]; p[1] += v * row[2]; p[2] += v * row[3];
      });
    }
    var t = values.slice(deltaCount);
    var head = rotation(t[0], t[1], t[2]);
    var torso = rotation(0, t[4], t[5]);
    return points.map(function (p, i) {
      var w = rig.headWeight[i];
      var q = turn(head, p, rig.headPivot);
      q[2] += t[3];
      p = [p[0] + w * (q[0] - p[0]), p[1] + w * (q[1] - p[1]), p[2] + w * (q[2] - p[2])];
      p = turn(torso, p, rig.torsoPivot);
      p[2] += t[6];
      var s = rig.focal / (rig.focal - p[2]);
      return [rig.origin[0] + s * p[0], rig.origin[1] + s * p[1]];
    });
  }

  function num(v) {
    var text = v.toFixed(2);
    return text === "-0.00" ? "0.00" : text;
  }

  function xy(p) { return num(p[0]) + " " + num(p[1]); }

  function curvePath(points, closed, corners) {
    var n = points.length;
    if (n === 1) { return "M " + xy(points[0]); }
    var incoming = [], outgoing = [];
    for (var i = 0; i < n; i++) {
      var hasPrev = closed || i > 0;
      var hasNext = closed || i < n - 1;
      var prev = points[(i - 1 + n) % n], next = points[(i + 1) % n], p = points[i];
      if (corners[i] || !(hasPrev && hasNext)) {
        incoming[i] = hasPrev ? [p[0] - prev[0], p[1] - prev[1]] : [next[0] - p[0], next[1] - p[1]];
        outgoing[i] = hasNext ? [next[0] - p[0], next[1] - p[1]] : [p[0] - prev[0], p[1] - prev[1]];
      } else {
        incoming[i] = outgoing[i] = [(next[0] - prev[0]) / 2, (next[1] - prev[1]) / 2];
      }
    }
    var parts = ["M " + xy(points[0])];
    var segments = closed ? n : n - 1;
    for (var k = 0; k < segments; k++) {
      var j = (k + 1) % n;
      var first = [points[k][0] + outgoing[k][0] / 3, points[k][1] + outgoing[k][1] / 3];
      var second = [points[j][0] - incoming[j][0] / 3, points[j][1] - incoming[j][1] / 3];
      parts.push("C " + xy(first) + " " + xy(second) + " " + xy(points[j]));
    }
    if (closed) { parts.push("Z"); }
    return parts.join(" ");
  }

  function ellipsePath(c, xAxis, yAxis) {
    var a = [xAxis[0] - c[0], xAxis[1] - c[1]];
    var b = [yAxis[0] - c[0], yAxis[1] - c[1]];
    var quarters = [[a, b], [b, [-a[0], -a[1]]], [[-a[0], -a[1]], [-b[0], -b[1]]], [[-b[0], -b[1]], a]];
    var parts = ["M " + xy([c[0] + a[0], c[1] + a[1]])];
    quarters.forEach(function (q) {
      var u = q[0], v = q[1];
      parts.push("C " + xy([c[0] + u[0] + KAPPA * v[0], c[1] + u[1] + KAPPA * v[1]]) + " " +
                 xy([c[0] + v[0] + KAPPA * u[0], c[1] + v[1] + KAPPA * u[1]]) + " " +
                 xy([c[0] + v[0], c[1] + v[1]]));
    });
    parts.push("Z");
    return parts.join(" ");
  }

  function shapePaths(t) {
    var values = channels(t);
    var screen = posePoints(values);
    return rig.shapes.map(function (shape) {
      var alpha = shape.opacity;
      shape.weights.forEach(function (w) { alpha += w[1] * values[w[0]]; });
      alpha = Math.min(1, Math.max(0, alpha));
      if (alpha <= 0) { return ["", 0]; }
      var members = shape.points.map(function (i) { return screen[i]; });
      var path = shape.kind === "ellipse"
        ? ellipsePath(members[0], members[1], members[2])
        : curvePath(members, shape.closed, shape.corners);
      return [path, alpha];
    });
  }

  function draw(t) {
    shapePaths(t).forEach(function (entry, i) {
      var node = paths[i];
      if (entry[0] === "") {
        node.setAttribute("visibility", "hidden");
        return;
      }
      node.setAttribute("visibility", "visible");
      node.setAttribute("d", entry[0]);
      node.setAttribute("opacity", entry[1].toFixed(3));
    });
    if (markerBox) {
      var active = track.markers.filter(function (m) { return m.start <= t && t < m.stop; });
      var text = active.map(function (m) { return "\u25B8 " + m.label; }).join("\n");
      if (markerBox.textContent !== text) { markerBox.textContent = text; }
    }
    svg.dataset.time = t.toFixed(3);
  }

  window.mseFace = { channels: channels, paths: shapePaths, draw: draw };
  document.addEventListener("mse-time", function (event) { draw(event.detail.time); });
  draw(0);
})();
