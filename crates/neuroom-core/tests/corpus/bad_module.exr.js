export default 'data:application/exr;base64,@@@@'
