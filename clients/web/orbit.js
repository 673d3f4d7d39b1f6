// orbit.js - an orbit camera: drag to rotate about a target, wheel to zoom, right-drag (or
// shift-drag) to pan. Y is up. The state survives reconnects because it lives outside the socket.
import * as THREE from './node_modules/three/build/three.module.js';

export class Orbit {
  constructor(camera, element, onChange) {
    this.camera = camera;
    this.target = new THREE.Vector3();
    this.radius = 4;
    this.theta = 0.6;  // azimuth about +Y
    this.phi = 1.2;    // from +Y
    this.onChange = onChange;
    let drag = null;
    element.addEventListener('contextmenu', e => e.preventDefault());
    element.addEventListener('pointerdown', e => {
      drag = { x: e.clientX, y: e.clientY, pan: e.button === 2 || e.shiftKey };
      element.setPointerCapture(e.pointerId);
    });
    element.addEventListener('pointerup', e => { drag = null; element.releasePointerCapture(e.pointerId); });
    element.addEventListener('pointermove', e => {
      if (!drag) return;
      const dx = e.clientX - drag.x, dy = e.clientY - drag.y;
      drag.x = e.clientX; drag.y = e.clientY;
      if (drag.pan) {
        const s = this.radius * 0.0015;
        const right = new THREE.Vector3().setFromMatrixColumn(this.camera.matrix, 0);
        const up = new THREE.Vector3().setFromMatrixColumn(this.camera.matrix, 1);
        this.target.addScaledVector(right, -dx * s).addScaledVector(up, dy * s);
      } else {
        this.theta -= dx * 0.008;
        this.phi = Math.min(Math.PI - 0.05, Math.max(0.05, this.phi - dy * 0.008));
      }
      this.update();
    });
    element.addEventListener('wheel', e => {
      e.preventDefault();
      this.radius = Math.min(1e4, Math.max(1e-3, this.radius * Math.exp(e.deltaY * 0.001)));
      this.update();
    }, { passive: false });
  }

  // Frames a box (min, max arrays) once; later calls are ignored so the user's view is kept.
  frame(min, max) {
    if (this.framed) return;
    this.framed = true;
    this.target.set((min[0] + max[0]) / 2, (min[1] + max[1]) / 2, (min[2] + max[2]) / 2);
    const d = Math.hypot(max[0] - min[0], max[1] - min[1], max[2] - min[2]);
    this.radius = 1.3 * d;
    this.camera.near = d / 1000;
    this.camera.far = d * 100;
    this.camera.updateProjectionMatrix();
    this.update();
  }

  update() {
    const s = Math.sin(this.phi);
    this.camera.position.set(this.target.x + this.radius * s * Math.sin(this.theta),
                             this.target.y + this.radius * Math.cos(this.phi),
                             this.target.z + this.radius * s * Math.cos(this.theta));
    this.camera.lookAt(this.target);
    this.camera.updateMatrixWorld();
    if (this.onChange) this.onChange();
  }
}
