// Entry point for the three.js bundle: build.mjs turns it into one IIFE that
// defines the global THREE (all of three.js plus THREE.OrbitControls).
export * from 'three';
export { OrbitControls } from 'three/addons/controls/OrbitControls.js';
