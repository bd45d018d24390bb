// kbplanner's 4D playback viewer: the parts of three.js it uses, bundled as one classic script.
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
window.KBP_THREE = { THREE, GLTFLoader, OrbitControls };
